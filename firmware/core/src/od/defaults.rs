//! The RAM image's defaults as od-gen emits them: only the runs that are not
//! zero. Most of a dictionary's defaults are zero (counters, mappings, spare
//! sub-indices), so the runs alone take a fraction of the image's flash.

/// The defaults of the RAM image: `len` bytes, zero but for `runs`.
#[derive(Debug, Clone, Copy)]
pub struct Defaults {
    /// Length of the RAM image.
    pub len: usize,
    /// Each run as (zeros before it, its length), in offset order: two bytes
    /// a run (a longer gap or run is split); a run's bytes end early where
    /// `bytes` does.
    pub runs: &'static [(u8, u8)],
    /// The runs' bytes, one after another.
    pub bytes: &'static [u8],
}

impl Defaults {
    /// Defaults given byte for byte (the image is `bytes`, at most 4,080 of
    /// them): runs from 0 on, as long as the bytes last.
    pub const fn dense(bytes: &'static [u8]) -> Self {
        Self { len: bytes.len(), runs: &[(0, u8::MAX); 16], bytes }
    }

    /// The defaults of `start..start + dst.len()` into `dst`. Byte by byte
    /// over the runs: the table is a few hundred bytes, and a short loop
    /// keeps the one reader small.
    pub fn read(&self, start: usize, dst: &mut [u8]) {
        dst.fill(0);
        let mut at = 0usize;
        // One iterator over the runs' bytes: each run takes its length of
        // them (fewer where they end), with no slicing of the table per run.
        let mut bytes = self.bytes.iter();
        for &(zeros, len) in self.runs {
            at = at.wrapping_add(zeros.into());
            for &b in bytes.by_ref().take(len.into()) {
                if let Some(d) = dst.get_mut(at.wrapping_sub(start)) {
                    *d = b;
                }
                at = at.wrapping_add(1);
            }
        }
    }
}
