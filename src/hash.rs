//! The 64-bit FNV-1a hash, for digests that must be the same on every
//! machine and Rust version: the farm's provenance (scene and source
//! digests) and a saved guide's checksum.

/// 64-bit FNV-1a (Fowler, Noll, Vo): a hash that is the same on every
/// machine and Rust version, unlike `std`'s, for provenance that farm nodes
/// compare. Not for security: it tells honest mistakes apart.
#[derive(Debug, Clone, Copy)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Hash more bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Hash a sequence of `len` items as 32-bit words, `len` first (so
    /// that consecutive sequences cannot be confused).
    pub(crate) fn words(&mut self, len: usize, w: impl IntoIterator<Item = u32>) {
        self.bytes(&(len as u64).to_le_bytes());
        for x in w {
            self.bytes(&x.to_le_bytes());
        }
    }

    /// Hash a sequence of `len` items as floats, by their bit patterns.
    pub(crate) fn floats(&mut self, len: usize, v: impl IntoIterator<Item = f32>) {
        self.words(len, v.into_iter().map(f32::to_bits));
    }

    /// The hash so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

impl std::fmt::Write for Fnv {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}
