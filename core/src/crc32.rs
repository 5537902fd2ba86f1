//! CRC-32 (IEEE 802.3, the zlib/PNG/Ethernet checksum), table-driven.
//!
//! Reflected polynomial `0xEDB88320`, initial value `0xFFFFFFFF`, final
//! XOR `0xFFFFFFFF`; check value `crc32(b"123456789") == 0xCBF43926`.
//! The 256-entry table is built at compile time; no heap, no `unsafe`,
//! no panics (indices are `u8`, the table has 256 entries).

/// Reflected IEEE polynomial.
pub const POLY: u32 = 0xEDB8_8320;

// index proven: `i < 256`, the table's length (a `const fn` has no iterators).
#[allow(clippy::indexing_slicing)]
const fn make_table() -> [u32; 256] {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 { POLY ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

static TABLE: [u32; 256] = make_table();

/// Incremental CRC-32 state: `Crc32::new()`, `update` with any number of
/// chunks, then `finish`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crc32 {
    state: u32,
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A fresh state (`0xFFFFFFFF`).
    pub const fn new() -> Self {
        Crc32 { state: 0xFFFF_FFFF }
    }

    /// Feeds bytes.
    // index proven: a `u8` index into the 256-entry table.
    #[allow(clippy::indexing_slicing)]
    pub fn update(&mut self, bytes: &[u8]) {
        let mut c = self.state;
        for &b in bytes {
            let idx = (c as u8) ^ b;
            c = TABLE[idx as usize] ^ (c >> 8);
        }
        self.state = c;
    }

    /// The checksum of everything fed so far.
    pub const fn finish(&self) -> u32 {
        self.state ^ 0xFFFF_FFFF
    }
}

/// CRC-32 (IEEE) of a byte slice.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = Crc32::new();
    c.update(bytes);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-by-bit reference, independent of the table.
    fn bitwise(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                let mask = (c & 1).wrapping_neg();
                c = (c >> 1) ^ (POLY & mask);
            }
        }
        !c
    }

    #[test]
    fn check_values() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        assert_eq!(
            crc32(b"The quick brown fox jumps over the lazy dog"),
            0x414F_A339
        );
    }

    #[test]
    fn incremental_and_bitwise_agree() {
        let data: std::vec::Vec<u8> = (0..1000u32).map(|i| (i * 37 % 251) as u8).collect();
        let mut c = Crc32::new();
        c.update(&data[..123]);
        c.update(&data[123..]);
        assert_eq!(c.finish(), crc32(&data));
        assert_eq!(crc32(&data), bitwise(&data));
    }
}
