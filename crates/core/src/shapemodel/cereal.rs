//! A bounded reader for cereal's portable binary archives, as eos writes them (little-endian).
//!
//! Every length read from the file is checked against the bytes that remain before anything is
//! allocated, so a corrupted or hostile file gives an error, never a huge allocation or a panic.

/// What went wrong at the byte level.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum CerealError {
    #[error("file ends early at byte {offset} (needed {needed} more bytes)")]
    Truncated { offset: usize, needed: usize },
    #[error("impossible size {value} at byte {offset}")]
    BadSize { offset: usize, value: i64 },
    #[error("text at byte {offset} is not UTF-8")]
    BadText { offset: usize },
}

pub struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, pos: 0 }
    }

    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], CerealError> {
        if n > self.remaining() {
            return Err(CerealError::Truncated {
                offset: self.pos,
                needed: n - self.remaining(),
            });
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], CerealError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }

    pub fn u32(&mut self) -> Result<u32, CerealError> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    pub fn i32(&mut self) -> Result<i32, CerealError> {
        Ok(i32::from_le_bytes(self.array()?))
    }

    pub fn u64(&mut self) -> Result<u64, CerealError> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    /// A `u64` element count, checked against the bytes left (`min_elem_bytes` each).
    pub fn len_prefix(&mut self, min_elem_bytes: usize) -> Result<usize, CerealError> {
        let offset = self.pos;
        let n = self.u64()?;
        let fits = usize::try_from(n).ok().filter(|&n| {
            n.checked_mul(min_elem_bytes.max(1))
                .is_some_and(|b| b <= self.remaining())
        });
        fits.ok_or(CerealError::BadSize {
            offset,
            value: i64::try_from(n).unwrap_or(i64::MAX),
        })
    }

    /// An Eigen float matrix: int32 rows, int32 cols, column-major data.
    pub fn f32_matrix(&mut self) -> Result<(u32, u32, Vec<f32>), CerealError> {
        let offset = self.pos;
        let rows = self.i32()?;
        let cols = self.i32()?;
        let bad = |value: i64| CerealError::BadSize { offset, value };
        let r = u32::try_from(rows).map_err(|_| bad(rows as i64))?;
        let c = u32::try_from(cols).map_err(|_| bad(cols as i64))?;
        let n = (r as usize)
            .checked_mul(c as usize)
            .filter(|n| n.checked_mul(4).is_some_and(|b| b <= self.remaining()))
            .ok_or_else(|| bad(rows as i64 * cols as i64))?;
        let raw = self.take(n * 4)?;
        let data = raw
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        Ok((r, c, data))
    }

    /// `std::vector<std::array<int, 3>>`: u64 count, then three int32 per triangle.
    pub fn triangles(&mut self) -> Result<Vec<[u32; 3]>, CerealError> {
        let n = self.len_prefix(12)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let offset = self.pos;
            let mut t = [0u32; 3];
            for v in &mut t {
                let i = self.i32()?;
                *v = u32::try_from(i).map_err(|_| CerealError::BadSize {
                    offset,
                    value: i as i64,
                })?;
            }
            out.push(t);
        }
        Ok(out)
    }

    /// `std::vector<std::array<double, 2>>`: u64 count, then two float64 each.
    pub fn texcoords(&mut self) -> Result<Vec<[f64; 2]>, CerealError> {
        let n = self.len_prefix(16)?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let u = f64::from_le_bytes(self.array()?);
            let v = f64::from_le_bytes(self.array()?);
            out.push([u, v]);
        }
        Ok(out)
    }

    /// `std::string`: u64 length, then bytes.
    pub fn string(&mut self) -> Result<String, CerealError> {
        let n = self.len_prefix(1)?;
        let offset = self.pos;
        let raw = self.take(n)?;
        String::from_utf8(raw.to_vec()).map_err(|_| CerealError::BadText { offset })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_round_trip() {
        let mut b = Vec::new();
        b.extend_from_slice(&2i32.to_le_bytes());
        b.extend_from_slice(&1i32.to_le_bytes());
        b.extend_from_slice(&1.5f32.to_le_bytes());
        b.extend_from_slice(&(-2.0f32).to_le_bytes());
        let mut r = Reader::new(&b);
        assert_eq!(r.f32_matrix().unwrap(), (2, 1, vec![1.5, -2.0]));
        assert_eq!(r.remaining(), 0);
    }

    #[test]
    fn huge_sizes_are_rejected_before_allocating() {
        let mut b = Vec::new();
        b.extend_from_slice(&i32::MAX.to_le_bytes());
        b.extend_from_slice(&i32::MAX.to_le_bytes());
        assert!(matches!(
            Reader::new(&b).f32_matrix(),
            Err(CerealError::BadSize { .. })
        ));
        let b = u64::MAX.to_le_bytes();
        assert!(matches!(
            Reader::new(&b).string(),
            Err(CerealError::BadSize { .. })
        ));
        assert!(matches!(
            Reader::new(&b).triangles(),
            Err(CerealError::BadSize { .. })
        ));
        let neg = [(-1i32).to_le_bytes(), 1i32.to_le_bytes()].concat();
        assert!(matches!(
            Reader::new(&neg).f32_matrix(),
            Err(CerealError::BadSize { .. })
        ));
    }

    #[test]
    fn truncation_is_reported() {
        let b = [1u8, 2];
        assert_eq!(
            Reader::new(&b).u32(),
            Err(CerealError::Truncated {
                offset: 0,
                needed: 2
            })
        );
    }
}
