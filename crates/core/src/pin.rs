//! The kiosk staff's PIN, stored in the configuration as a salted hash (never the PIN):
//! PBKDF2-HMAC-SHA256 (RFC 8018) over the PIN with a random 16-byte salt, written
//! `pbkdf2-sha256$<iterations>$<salt, hex>$<hash, hex>`. A PIN is checked by hashing the
//! attempt with the stored salt and comparing in constant time. A few digits are not a
//! password: the hash keeps the PIN out of a configuration file that is read over a
//! shoulder or copied, and the kiosk's tries-then-pause keeps guessing at the screen slow.
//! No I/O here: the salt is the caller's (`glyptic kiosk --hash-pin` reads the system's
//! random source).

use sha2::{Digest as _, Sha256};

/// The iterations a new hash uses: 15 ms on one core of the project's VM, once per
/// attempt (staff type a PIN rarely; a guesser pays it every time).
pub const ITERATIONS: u32 = 60_000;
/// The fewest and most digits a PIN may have.
pub const DIGITS: std::ops::RangeInclusive<usize> = 4..=12;
const SCHEME: &str = "pbkdf2-sha256";

/// Why a stored PIN hash or a new PIN was refused.
#[derive(Debug, PartialEq, Eq, thiserror::Error)]
pub enum PinError {
    #[error(
        "is not `pbkdf2-sha256$ITERATIONS$SALT$HASH` (make one with `glyptic kiosk --hash-pin`)"
    )]
    Format,
    #[error("has {0} iterations; at least 1000 and at most 10000000")]
    Iterations(u32),
    #[error("a PIN is 4 to 12 digits")]
    Digits,
}

/// A stored PIN: its salt, iterations and hash.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StaffPin {
    iterations: u32,
    salt: Vec<u8>,
    hash: [u8; 32],
}

impl StaffPin {
    /// Hashes a new PIN (4-12 digits) with `salt` (16 random bytes from the caller).
    pub fn new(pin: &str, salt: [u8; 16]) -> Result<Self, PinError> {
        if !DIGITS.contains(&pin.len()) || !pin.bytes().all(|b| b.is_ascii_digit()) {
            return Err(PinError::Digits);
        }
        Ok(StaffPin {
            iterations: ITERATIONS,
            hash: pbkdf2_sha256(pin.as_bytes(), &salt, ITERATIONS),
            salt: salt.to_vec(),
        })
    }

    /// Reads the configuration's form.
    pub fn parse(text: &str) -> Result<Self, PinError> {
        let mut parts = text.trim().split('$');
        let (Some(SCHEME), Some(iterations), Some(salt), Some(hash), None) = (
            parts.next(),
            parts.next(),
            parts.next(),
            parts.next(),
            parts.next(),
        ) else {
            return Err(PinError::Format);
        };
        let iterations: u32 = iterations.parse().map_err(|_| PinError::Format)?;
        if !(1000..=10_000_000).contains(&iterations) {
            return Err(PinError::Iterations(iterations));
        }
        let salt = from_hex(salt).filter(|s| (8..=64).contains(&s.len()));
        let hash = from_hex(hash).and_then(|h| <[u8; 32]>::try_from(h).ok());
        match (salt, hash) {
            (Some(salt), Some(hash)) => Ok(StaffPin {
                iterations,
                salt,
                hash,
            }),
            _ => Err(PinError::Format),
        }
    }

    /// Whether `attempt` is the PIN, compared in constant time (every byte of the hashes
    /// is looked at, whatever the first difference).
    pub fn matches(&self, attempt: &str) -> bool {
        let got = pbkdf2_sha256(attempt.as_bytes(), &self.salt, self.iterations);
        let diff = got
            .iter()
            .zip(&self.hash)
            .fold(0u8, |acc, (a, b)| acc | (a ^ b));
        std::hint::black_box(diff) == 0
    }
}

impl std::fmt::Display for StaffPin {
    /// The configuration's form (`staff_pin = "..."`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{SCHEME}${}${}${}",
            self.iterations,
            to_hex(&self.salt),
            to_hex(&self.hash)
        )
    }
}

fn to_hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn from_hex(text: &str) -> Option<Vec<u8>> {
    if !text.len().is_multiple_of(2) || !text.is_ascii() {
        return None;
    }
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).ok())
        .collect()
}

/// HMAC-SHA256 (RFC 2104) of `parts` concatenated, keyed by `key`.
fn hmac_sha256(key: &[u8], parts: &[&[u8]]) -> [u8; 32] {
    let mut block = [0u8; 64];
    if key.len() > 64 {
        block[..32].copy_from_slice(&Sha256::digest(key));
    } else {
        block[..key.len()].copy_from_slice(key);
    }
    let mut inner = Sha256::new();
    inner.update(block.map(|b| b ^ 0x36));
    for p in parts {
        inner.update(p);
    }
    let mut outer = Sha256::new();
    outer.update(block.map(|b| b ^ 0x5c));
    outer.update(inner.finalize());
    outer.finalize().into()
}

/// PBKDF2 with HMAC-SHA256 (RFC 8018), one 32-byte block.
fn pbkdf2_sha256(password: &[u8], salt: &[u8], iterations: u32) -> [u8; 32] {
    let mut u = hmac_sha256(password, &[salt, &1u32.to_be_bytes()]);
    let mut out = u;
    for _ in 1..iterations {
        u = hmac_sha256(password, &[&u]);
        for (o, x) in out.iter_mut().zip(&u) {
            *o ^= x;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pbkdf2_matches_the_published_vectors() {
        // PBKDF2-HMAC-SHA256, P = "password", S = "salt", 32 bytes (as RFC 7914 section 11
        // lists them and every implementation reproduces).
        for (c, want) in [
            (
                1,
                "120fb6cffcf8b32c43e7225256c4f837a86548c92ccc35480805987cb70be17b",
            ),
            (
                2,
                "ae4d0c95af6b46d32d0adff928f06dd02a303f8ef3c251dfd6e2d85a95474c43",
            ),
            (
                4096,
                "c5e478d59288c841aa530db6845c4c8d962893a001ce4e11a4963873aa98134a",
            ),
        ] {
            assert_eq!(
                to_hex(&pbkdf2_sha256(b"password", b"salt", c)),
                want,
                "c = {c}"
            );
        }
        // HMAC-SHA256, RFC 4231 test case 2.
        assert_eq!(
            to_hex(&hmac_sha256(
                b"Jefe",
                &[b"what do ya want ", b"for nothing?"]
            )),
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"
        );
    }

    #[test]
    fn a_stored_pin_opens_only_for_its_pin() {
        let pin = StaffPin::new("2718", [7; 16]).unwrap();
        let stored = pin.to_string();
        assert!(stored.starts_with("pbkdf2-sha256$60000$0707"), "{stored}");
        assert!(!stored.contains("2718"));
        let back = StaffPin::parse(&stored).unwrap();
        assert_eq!(back, pin);
        assert!(back.matches("2718"));
        for wrong in ["2719", "", "27180", "271", "abcd", "2718 "] {
            assert!(!back.matches(wrong), "{wrong:?}");
        }
        // Another salt, another hash.
        assert_ne!(StaffPin::new("2718", [8; 16]).unwrap().hash, pin.hash);
    }

    #[test]
    fn bad_pins_and_stored_forms_are_refused() {
        for pin in ["123", "1234567890123", "12a4", "", "١٢٣٤"] {
            assert_eq!(
                StaffPin::new(pin, [0; 16]),
                Err(PinError::Digits),
                "{pin:?}"
            );
        }
        let good = StaffPin::new("1234", [1; 16]).unwrap().to_string();
        let hash = good.rsplit('$').next().unwrap().to_owned();
        for bad in [
            "1234",
            "",
            "sha1$60000$00$00",
            "pbkdf2-sha256$60000$0101",
            "pbkdf2-sha256$x$01010101010101010101010101010101$00",
            &good.replace(&hash, &hash[..62]),
            &format!("{good}$extra"),
            "pbkdf2-sha256$60000$zz$00",
        ] {
            assert_eq!(StaffPin::parse(bad), Err(PinError::Format), "{bad:?}");
        }
        assert_eq!(
            StaffPin::parse(&good.replace("$60000$", "$10$")),
            Err(PinError::Iterations(10))
        );
    }
}
