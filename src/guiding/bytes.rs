//! The little-endian byte writer and checked reader that a saved guide
//! ([`super::persist`]) and its quadtrees ([`super::dtree`]) are written
//! and read with.

/// Most spatial nodes or leaves a guide may claim (far beyond what
/// training grows: a few thousand leaves), so that a corrupt count cannot
/// ask for gigabytes before the bytes run out.
const MAX_ENTRIES: u32 = 1 << 26;

/// Bytes being written.
#[derive(Default)]
pub(crate) struct Writer(Vec<u8>);

impl Writer {
    pub(crate) fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    pub(crate) fn as_slice(&self) -> &[u8] {
        &self.0
    }
    pub(crate) fn into_vec(self) -> Vec<u8> {
        self.0
    }
    pub(crate) fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    pub(crate) fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub(crate) fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    /// A length, which the formats keep below [`MAX_ENTRIES`].
    pub(crate) fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("a guide's counts fit in u32"));
    }
}

/// Bytes being read, with the reason the first bad one is refused.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

/// Why saved bytes are not a guide.
pub(crate) type Refusal = String;

impl<'a> Reader<'a> {
    /// A reader of `bytes` from byte `at`.
    pub(crate) fn new(bytes: &'a [u8], at: usize) -> Self {
        Reader { bytes, at }
    }
    /// Bytes not read yet.
    pub(crate) fn left(&self) -> usize {
        self.bytes.len() - self.at
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8], Refusal> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or_else(|| format!("truncated at byte {}", self.at))?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    pub(crate) fn u8(&mut self) -> Result<u8, Refusal> {
        Ok(self.take(1)?[0])
    }
    pub(crate) fn u32(&mut self) -> Result<u32, Refusal> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    pub(crate) fn f32(&mut self) -> Result<f32, Refusal> {
        Ok(f32::from_bits(self.u32()?))
    }
    /// A count of entries of at least `min_bytes` each: at most
    /// [`MAX_ENTRIES`], and no more than the bytes left could hold.
    pub(crate) fn count(&mut self, what: &str, min_bytes: usize) -> Result<usize, Refusal> {
        let n = self.u32()?;
        if n > MAX_ENTRIES || (n as usize).saturating_mul(min_bytes) > self.left() {
            return Err(format!("{n} {what}: more than the file holds"));
        }
        Ok(n as usize)
    }
    /// `n` entries of `bytes` each must remain.
    pub(crate) fn count_exact(&self, n: usize, bytes: usize) -> Result<usize, Refusal> {
        if n.saturating_mul(bytes) > self.left() {
            return Err(format!("{n} entries: more than the file holds"));
        }
        Ok(n)
    }
}
