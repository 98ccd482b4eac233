//! A bounded, panic-free reader of dlib's binary serialization format (`dlib/serialize.h`).
//!
//! Only the pieces a `dlib::shape_predictor` file uses are here:
//!
//! * **Integers** are a control byte followed by 1 to 8 little-endian magnitude bytes. The
//!   control byte's low 4 bits give the byte count; for signed types bit `0x80` is the sign
//!   (the magnitude is stored, not two's complement). Zero is written as `01 00`. Unsigned
//!   types keep bits `0x8F` of the control byte, so a set sign bit makes the count invalid.
//!   A count of 0 or more bytes than the C++ type holds is an error, as in dlib.
//! * **Floats** are a `float_details`: a signed 64-bit mantissa, then a signed 16-bit
//!   exponent, both as integers above; the value is `mantissa * 2^exponent`, except the
//!   exponent codes 32000 (+inf), 32001 (-inf) and >= 32002 (NaN). dlib's pre-2013 ASCII
//!   float format (recognised by a first byte with any of bits `0x70` set) is rejected.
//! * **`std::vector<T>`** is an `unsigned long` length followed by the elements.
//! * **`dlib::matrix<T,NR,NC>`** is `-rows`, `-cols` (as `long`; older files wrote them
//!   positive) followed by the elements in row-major order.
//! * **`dlib::vector<T,2>`** is `x` then `y`.
//!
//! Bounds: every read checks the remaining input first and returns
//! [`LandmarkError::Format`] naming the byte offset and field, never panicking. A length
//! prefix is checked against the bytes left before anything is allocated for it (see
//! [`Reader::read_len`]), so a corrupt length can never make us reserve more memory than
//! the input could possibly describe.
//!
//! Sizes assume an LP64 writer (Linux/macOS), where `long` is 8 bytes; values that fit in
//! 4 bytes (all real model files) read the same whatever the writer was.

use super::LandmarkError;

/// `float_details::is_inf`: the exponent code dlib writes for +infinity.
pub const EXP_INF: i16 = 32000;
/// `float_details::is_ninf`: the exponent code for -infinity.
pub const EXP_NINF: i16 = 32001;
/// `float_details::is_nan`: the exponent code for NaN (dlib reads any larger code as NaN too).
pub const EXP_NAN: i16 = 32002;

/// Smallest encoding of one integer: control byte plus one magnitude byte.
pub const MIN_INT_BYTES: usize = 2;
/// Smallest encoding of one float: two integers (mantissa and exponent).
pub const MIN_FLOAT_BYTES: usize = 2 * MIN_INT_BYTES;

/// A cursor over a byte slice that decodes dlib's serialization primitives.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    /// A reader positioned at the start of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0 }
    }

    /// Byte offset of the next read.
    pub fn position(&self) -> usize {
        self.pos
    }

    /// Bytes not yet consumed.
    pub fn remaining(&self) -> usize {
        self.bytes.len().saturating_sub(self.pos)
    }

    /// True when every byte has been consumed.
    pub fn is_at_end(&self) -> bool {
        self.remaining() == 0
    }

    /// A format error at the current position.
    pub fn error(&self, field: &str, problem: impl Into<String>) -> LandmarkError {
        LandmarkError::Format {
            offset: self.pos,
            field: field.to_string(),
            problem: problem.into(),
        }
    }

    fn byte(&mut self, field: &str) -> Result<u8, LandmarkError> {
        match self.bytes.get(self.pos) {
            Some(&b) => {
                self.pos += 1;
                Ok(b)
            }
            None => Err(self.error(field, "unexpected end of data")),
        }
    }

    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    /// Reads `count` (1..=8) little-endian magnitude bytes of the integer whose control
    /// byte was at `start` (where an error is reported, and the position is left).
    fn magnitude(&mut self, field: &str, count: usize, start: usize) -> Result<u64, LandmarkError> {
        let end = match self.pos.checked_add(count) {
            Some(end) if end <= self.bytes.len() => end,
            _ => {
                self.pos = start;
                return Err(self.error(
                    field,
                    format!("unexpected end of data (integer needs {count} bytes after its control byte)"),
                ));
            }
        };
        let mut value = 0u64;
        for &b in self.bytes[self.pos..end].iter().rev() {
            value = (value << 8) | u64::from(b);
        }
        self.pos = end;
        Ok(value)
    }

    /// Reads an unsigned integer written by dlib for a C++ type of `type_bytes` bytes
    /// (e.g. 8 for `unsigned long` on LP64). Errors if the value exceeds that type.
    pub fn read_unsigned(&mut self, field: &str, type_bytes: usize) -> Result<u64, LandmarkError> {
        let start = self.pos;
        let control = self.byte(field)?;
        // dlib masks out the three reserved bits; the sign bit stays and so makes the
        // count invalid for an unsigned type.
        let count = usize::from(control & 0x8F);
        if count == 0 || count > type_bytes.min(8) {
            self.pos = start;
            return Err(self.error(
                field,
                format!(
                    "invalid control byte 0x{control:02x} for a {type_bytes}-byte unsigned integer"
                ),
            ));
        }
        self.magnitude(field, count, start)
    }

    /// Reads a signed integer written by dlib for a C++ type of `type_bytes` bytes
    /// (4 for `int`, 8 for `long` on LP64, 2 for `short`). Errors if the value does not fit.
    pub fn read_signed(&mut self, field: &str, type_bytes: usize) -> Result<i64, LandmarkError> {
        let start = self.pos;
        let control = self.byte(field)?;
        let negative = control & 0x80 != 0;
        let count = usize::from(control & 0x0F);
        let type_bytes = type_bytes.clamp(1, 8);
        if count == 0 || count > type_bytes {
            self.pos = start;
            return Err(self.error(
                field,
                format!(
                    "invalid control byte 0x{control:02x} for a {type_bytes}-byte signed integer"
                ),
            ));
        }
        let magnitude = self.magnitude(field, count, start)?;
        // The largest magnitude the C++ type holds: 2^(8n-1) - 1 positive, 2^(8n-1) negative.
        let limit = 1u64 << (8 * type_bytes - 1);
        let fits = if negative {
            magnitude <= limit
        } else {
            magnitude < limit
        };
        if !fits {
            self.pos = start;
            return Err(self.error(
                field,
                format!(
                    "integer magnitude {magnitude} does not fit a {type_bytes}-byte signed type"
                ),
            ));
        }
        // Cannot overflow: magnitude <= 2^63 was checked, and 2^63 only when negative.
        Ok(if negative {
            0i64.wrapping_sub_unsigned(magnitude)
        } else {
            magnitude as i64
        })
    }

    /// A C++ `int` (4 bytes).
    pub fn read_i32(&mut self, field: &str) -> Result<i32, LandmarkError> {
        // read_signed(.., 4) guarantees the value fits in i32.
        let v = self.read_signed(field, 4)?;
        i32::try_from(v).map_err(|_| self.error(field, "integer out of range"))
    }

    /// A C++ `long` (8 bytes on LP64).
    pub fn read_long(&mut self, field: &str) -> Result<i64, LandmarkError> {
        self.read_signed(field, 8)
    }

    /// A C++ `unsigned long` (8 bytes on LP64).
    pub fn read_ulong(&mut self, field: &str) -> Result<u64, LandmarkError> {
        self.read_unsigned(field, 8)
    }

    /// The two integers of a `float_details`: (mantissa, exponent).
    fn float_parts(&mut self, field: &str) -> Result<(i64, i16), LandmarkError> {
        match self.peek() {
            None => return Err(self.error(field, "unexpected end of data")),
            Some(b) if b & 0x70 != 0 => {
                return Err(self.error(
                    field,
                    format!("byte 0x{b:02x} starts dlib's old ASCII float format, which is not supported"),
                ));
            }
            Some(_) => {}
        }
        let mantissa = self.read_signed(field, 8)?;
        let exponent = self.read_signed(field, 2)?;
        // read_signed(.., 2) guarantees the range of i16.
        let exponent =
            i16::try_from(exponent).map_err(|_| self.error(field, "exponent out of range"))?;
        Ok((mantissa, exponent))
    }

    /// A `float`, converted as dlib's `float_details::convert_to_T<float>` does:
    /// the mantissa is rounded to `f32` first, then scaled by a power of two.
    pub fn read_f32(&mut self, field: &str) -> Result<f32, LandmarkError> {
        let (mantissa, exponent) = self.float_parts(field)?;
        Ok(f32_from_parts(mantissa, exponent))
    }

    /// A `double`, converted like [`Reader::read_f32`] but in `f64`.
    pub fn read_f64(&mut self, field: &str) -> Result<f64, LandmarkError> {
        let (mantissa, exponent) = self.float_parts(field)?;
        Ok(f64_from_parts(mantissa, exponent))
    }

    /// A `float` that must be finite (model parameters; a NaN would silently poison every
    /// prediction, so it is better refused at load time).
    pub fn read_finite_f32(&mut self, field: &str) -> Result<f32, LandmarkError> {
        let start = self.pos;
        let v = self.read_f32(field)?;
        if v.is_finite() {
            Ok(v)
        } else {
            self.pos = start;
            Err(self.error(field, format!("non-finite value {v}")))
        }
    }

    /// A `std::vector` length prefix. `min_item_bytes` is the fewest bytes one element can
    /// take; a length that could not fit in the bytes left is refused here, so callers may
    /// reserve `len` elements without trusting the input.
    pub fn read_len(&mut self, field: &str, min_item_bytes: usize) -> Result<usize, LandmarkError> {
        let start = self.pos;
        let len = self.read_ulong(field)?;
        let need = (len as u128) * (min_item_bytes.max(1) as u128);
        if need > self.remaining() as u128 {
            self.pos = start;
            return Err(self.error(
                field,
                format!(
                    "length {len} cannot fit in the {} bytes left (at least {min_item_bytes} bytes each)",
                    self.remaining()
                ),
            ));
        }
        // need <= remaining <= usize::MAX, so len fits in usize.
        usize::try_from(len).map_err(|_| self.error(field, "length out of range"))
    }

    /// The dimensions of a `dlib::matrix`: (rows, cols), accepting both the current
    /// (negated) and the old (positive) encoding. Refuses a matrix whose elements could not
    /// fit in the bytes left at `min_item_bytes` each.
    pub fn read_matrix_dims(
        &mut self,
        field: &str,
        min_item_bytes: usize,
    ) -> Result<(usize, usize), LandmarkError> {
        let start = self.pos;
        let mut nr = self.read_long(field)?;
        let mut nc = self.read_long(field)?;
        if nr < 0 || nc < 0 {
            nr = nr.saturating_neg();
            nc = nc.saturating_neg();
        }
        if nr < 0 || nc < 0 {
            self.pos = start;
            return Err(self.error(field, format!("invalid matrix size {nr} x {nc}")));
        }
        let need = (nr as u128) * (nc as u128) * (min_item_bytes.max(1) as u128);
        if need > self.remaining() as u128 {
            self.pos = start;
            return Err(self.error(
                field,
                format!(
                    "a {nr} x {nc} matrix cannot fit in the {} bytes left",
                    self.remaining()
                ),
            ));
        }
        Ok((nr as usize, nc as usize))
    }

    /// A `dlib::matrix<float,0,1>` (column vector) appended to `out`; returns its length.
    pub fn read_column_f32_into(
        &mut self,
        field: &str,
        out: &mut Vec<f32>,
    ) -> Result<usize, LandmarkError> {
        let start = self.pos;
        let (nr, nc) = self.read_matrix_dims(field, MIN_FLOAT_BYTES)?;
        if nc != 1 && nr != 0 {
            self.pos = start;
            return Err(self.error(
                field,
                format!("expected a column vector, found {nr} x {nc}"),
            ));
        }
        out.reserve(nr);
        for _ in 0..nr {
            out.push(self.read_finite_f32(field)?);
        }
        Ok(nr)
    }

    /// A `dlib::vector<float,2>`.
    pub fn read_point_f32(&mut self, field: &str) -> Result<[f32; 2], LandmarkError> {
        let x = self.read_finite_f32(field)?;
        let y = self.read_finite_f32(field)?;
        Ok([x, y])
    }
}

/// `x * 2^e` for one float type, like C's `ldexp`, for any `e`: scales in steps of the
/// largest (smallest) normal power of two, which stay exact until the result itself over- or
/// underflows. `$bias`, `$mantissa`: the type's exponent bias and mantissa bits.
macro_rules! ldexp {
    ($(#[$doc:meta])* $name:ident, $parts:ident, $t:ty, $bits:ty, $bias:literal,
        $mantissa:literal) => {
        /// The value of dlib's (mantissa, exponent) pair, the special exponents included:
        /// the mantissa rounded to this type first, then scaled by a power of two.
        fn $parts(mantissa: i64, exponent: i16) -> $t {
            match exponent {
                EXP_INF => <$t>::INFINITY,
                EXP_NINF => <$t>::NEG_INFINITY,
                e if e >= EXP_NAN => <$t>::NAN,
                e => $name(mantissa as $t, i32::from(e)),
            }
        }

        $(#[$doc])*
        pub fn $name(mut x: $t, mut e: i32) -> $t {
            // 2^k for k in [1 - bias, bias], built from the exponent bits.
            fn pow2(k: i32) -> $t {
                <$t>::from_bits(((k + $bias) as $bits) << $mantissa)
            }
            while e > $bias {
                x *= pow2($bias);
                e -= $bias;
                if !x.is_finite() || x == 0.0 {
                    return x;
                }
            }
            while e < 1 - $bias {
                x *= pow2(1 - $bias);
                e += $bias - 1;
                if x == 0.0 {
                    return x;
                }
            }
            x * pow2(e)
        }
    };
}

ldexp!(
    /// `x * 2^e` in `f32`, like C's `ldexpf`.
    ldexp_f32, f32_from_parts, f32, u32, 127, 23
);
ldexp!(
    /// `x * 2^e` in `f64`, like C's `ldexp`.
    ldexp_f64, f64_from_parts, f64, u64, 1023, 52
);

/// Encoders, the inverse of [`Reader`], for building test data and small model files.
pub mod write {
    /// Appends a signed integer in dlib's format.
    pub fn signed(out: &mut Vec<u8>, value: i64) {
        magnitude(out, value.unsigned_abs(), value < 0);
    }

    /// Appends an unsigned integer in dlib's format.
    pub fn unsigned(out: &mut Vec<u8>, value: u64) {
        magnitude(out, value, false);
    }

    /// dlib's integer: a byte with the length (and the sign in its top bit), then the
    /// magnitude's bytes, least significant first (at least one).
    fn magnitude(out: &mut Vec<u8>, mut mag: u64, negative: bool) {
        let mut buf = [0u8; 8];
        let mut n = 0;
        loop {
            buf[n] = (mag & 0xFF) as u8;
            n += 1;
            mag >>= 8;
            if mag == 0 || n == 8 {
                break;
            }
        }
        out.push(n as u8 | if negative { 0x80 } else { 0 });
        out.extend_from_slice(&buf[..n]);
    }

    /// Appends a float as dlib's `float_details` (mantissa, exponent), trimming zero low
    /// bytes of the mantissa as dlib does.
    pub fn float(out: &mut Vec<u8>, value: f64) {
        let (mantissa, exponent) = if value.is_nan() {
            (0i64, super::EXP_NAN)
        } else if value == f64::INFINITY {
            (0, super::EXP_INF)
        } else if value == f64::NEG_INFINITY {
            (0, super::EXP_NINF)
        } else if value == 0.0 {
            (0, 0)
        } else {
            // value = m * 2^e with m an integer of up to 53 bits.
            let bits = value.to_bits();
            let raw_exp = ((bits >> 52) & 0x7FF) as i32;
            let frac = bits & ((1u64 << 52) - 1);
            let (mut m, mut e) = if raw_exp == 0 {
                (frac as i64, -1074)
            } else {
                ((frac | (1u64 << 52)) as i64, raw_exp - 1075)
            };
            for _ in 0..8 {
                if m & 0xFF != 0 {
                    break;
                }
                m >>= 8;
                e += 8;
            }
            if value < 0.0 {
                m = -m;
            }
            (m, e as i16)
        };
        signed(out, mantissa);
        signed(out, i64::from(exponent));
    }
}

#[cfg(test)]
mod tests {
    use super::{ldexp_f32, ldexp_f64};

    /// Both widths scale exactly through the normal range, into subnormals, and saturate.
    #[test]
    fn ldexp_scales_exactly_and_saturates() {
        assert_eq!(ldexp_f32(1.0, 10), 1024.0);
        assert_eq!(ldexp_f32(3.0, -2), 0.75);
        // 1.5 * 2^-130 = 786432 * 2^-149, a subnormal.
        assert_eq!(ldexp_f32(1.5, -130), f32::from_bits(786_432));
        assert_eq!(ldexp_f32(1.0, 200), f32::INFINITY);
        assert_eq!(ldexp_f32(1.0e30, -400), 0.0);
        assert_eq!(ldexp_f32(2.0f32.powi(-100), 227), 2.0f32.powi(127));
        assert_eq!(ldexp_f64(1.0, 1000), 2.0f64.powi(1000));
        // 3 * 2^-1070 = 48 * 2^-1074, a subnormal.
        assert_eq!(ldexp_f64(3.0, -1070), f64::from_bits(48));
        assert_eq!(ldexp_f64(-1.0, 5000), f64::NEG_INFINITY);
        assert_eq!(ldexp_f64(1.0, -5000), 0.0);
    }
}
