//! A file on the machine QEMU runs on, reached through ARM semihosting
//! (SYS_OPEN, SYS_FLEN, SYS_SEEK, SYS_READ, SYS_WRITE), so the RAM storage
//! survives QEMU's exit: a power cycle of the emulated board. Used only when
//! [`NAME`] exists in QEMU's working directory (`cargo xtask hil` makes it);
//! the smoke tests and the demo run without it, as before.
#![allow(unsafe_code)]

use core::num::NonZeroUsize;

/// The file's name, NUL-terminated for SYS_OPEN.
pub const NAME: &str = "canopen-qemu-storage.bin\0";

/// An open host file (the semihosting handle plus one, so `None` is zero).
#[derive(Clone, Copy, Debug)]
pub struct HostFile(NonZeroUsize);

impl HostFile {
    /// Opens [`NAME`] for reading and writing, if it exists.
    pub fn open() -> Option<HostFile> {
        #[cfg(all(target_os = "none", feature = "board-qemu"))]
        {
            // SAFETY: SYS_OPEN reads the NUL-terminated name and its length (without the NUL).
            let fd =
                unsafe { cortex_m_semihosting::syscall!(OPEN, NAME.as_ptr(), cortex_m_semihosting::nr::open::RW_BINARY, NAME.len() - 1) };
            let file = NonZeroUsize::new(fd.wrapping_add(1)).map(HostFile);
            if file.is_some() {
                defmt::info!("storage: backed by the host file {=str}", NAME.trim_end_matches('\0'));
            }
            file
        }
        #[cfg(not(all(target_os = "none", feature = "board-qemu")))]
        None
    }

    fn handle(self) -> usize {
        self.0.get() - 1
    }

    /// The file's length in bytes (0 if unknown).
    pub fn size(self) -> usize {
        #[cfg(all(target_os = "none", feature = "board-qemu"))]
        {
            // SAFETY: SYS_FLEN takes the handle only.
            let len = unsafe { cortex_m_semihosting::syscall!(FLEN, self.handle()) };
            if len == usize::MAX { 0 } else { len }
        }
        #[cfg(not(all(target_os = "none", feature = "board-qemu")))]
        {
            let _ = self.handle();
            0
        }
    }

    /// Reads `buf.len()` bytes at `offset`; whether all came.
    pub fn read_at(self, offset: usize, buf: &mut [u8]) -> bool {
        #[cfg(all(target_os = "none", feature = "board-qemu"))]
        {
            // SAFETY: SYS_SEEK takes the handle and a position; SYS_READ
            // writes at most `buf.len()` bytes into `buf`.
            unsafe {
                cortex_m_semihosting::syscall!(SEEK, self.handle(), offset) == 0
                    && cortex_m_semihosting::syscall!(READ, self.handle(), buf.as_mut_ptr(), buf.len()) == 0
            }
        }
        #[cfg(not(all(target_os = "none", feature = "board-qemu")))]
        {
            let _ = (self.handle(), offset, buf);
            false
        }
    }

    /// Writes `data` at `offset`; whether all of it went.
    pub fn write_at(self, offset: usize, data: &[u8]) -> bool {
        #[cfg(all(target_os = "none", feature = "board-qemu"))]
        {
            // SAFETY: SYS_SEEK takes the handle and a position; SYS_WRITE
            // reads `data.len()` bytes from `data`.
            unsafe {
                cortex_m_semihosting::syscall!(SEEK, self.handle(), offset) == 0
                    && cortex_m_semihosting::syscall!(WRITE, self.handle(), data.as_ptr(), data.len()) == 0
            }
        }
        #[cfg(not(all(target_os = "none", feature = "board-qemu")))]
        {
            let _ = (self.handle(), offset, data);
            false
        }
    }
}
