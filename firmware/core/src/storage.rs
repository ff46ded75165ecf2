//! Non-volatile storage as the core needs it for store/restore (0x1010/0x1011)
//! and the LSS configuration: two regions written like flash (erase, then
//! program), so a new parameter set goes to the region not in use and an
//! interrupted write leaves the old set intact.

/// Why storage failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StorageError {
    /// Region or range outside the device.
    OutOfRange,
    /// The device reported a failure (or, in tests, the power was cut).
    Failed,
}

/// Two equal regions of erasable memory.
pub trait Storage {
    /// Size of each region in bytes.
    fn region_size(&self) -> usize;
    /// Reads `buf.len()` bytes at `offset` of `region` (0 or 1).
    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError>;
    /// Sets every byte of `region` to 0xFF.
    fn erase(&mut self, region: u8) -> Result<(), StorageError>;
    /// Programs `data` at `offset` of an erased part of `region`.
    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError>;
}
