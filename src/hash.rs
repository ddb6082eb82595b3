//! FNV-1a, 64 bits: a hash that is stable across runs, platforms and Rust versions (unlike
//! `std`'s hasher), for what must compare equal between pirs and machines: a scene's
//! fingerprint, and the pixel hashes that show an image unchanged (`tests/golden.rs`,
//! `examples/exr_hash.rs`).

/// The running hash.
#[derive(Clone, Copy, Debug)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xCBF2_9CE4_8422_2325)
    }
}

impl Fnv1a {
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01B3);
        }
    }

    /// Each value's bits, little-endian.
    pub fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }

    /// Each value's bits, little-endian.
    pub fn f64s(&mut self, v: &[f64]) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }

    pub fn u32s(&mut self, v: &[u32]) {
        for x in v {
            self.bytes(&x.to_le_bytes());
        }
    }

    pub fn u64s(&mut self, v: &[u64]) {
        for x in v {
            self.bytes(&x.to_le_bytes());
        }
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}
