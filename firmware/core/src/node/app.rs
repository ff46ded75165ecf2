//! The device's side of a node: hooks where the five devices differ.

use crate::abort::AbortCode;
use crate::services::nmt::State;
use crate::wire::time_stamp::TimeOfDay;

/// Hooks a device implements; every method has a default, so a device
/// module overrides only what its manual asks for.
///
/// The `read`/`write` hooks see application objects (0x2000 and up) before
/// the generated dictionary does. They return `None` to let the dictionary
/// handle the access, or `Some` to answer it themselves: a parameter backend
/// (the b maXX 4400's 0x4000 + parameter number), a DOMAIN, or a value that
/// must be checked against the device state (abort 0x08000022).
pub trait Application {
    /// Size of the value an upload of (index, sub) sends, if the application serves it.
    fn upload_size(&mut self, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        let _ = (index, sub);
        None
    }

    /// Bytes `offset..` of a value the application serves.
    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
        let _ = (index, sub, offset, buf);
        None
    }

    /// Checks a download before it starts, if the application serves (index, sub).
    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        let _ = (index, sub, size);
        None
    }

    /// A complete download to (index, sub): `Some(Err)` refuses it,
    /// `Some(Ok)` means the application stored it, `None` lets the
    /// dictionary store it (after its own checks).
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        let _ = (index, sub, data);
        None
    }

    /// The NMT state changed.
    fn on_state(&mut self, state: State) {
        let _ = state;
    }

    /// RPDO `n` (0-based) wrote its data into the dictionary.
    fn on_rpdo(&mut self, n: usize) {
        let _ = n;
    }

    /// A SYNC was received or produced (after the synchronous PDOs ran).
    fn on_sync(&mut self) {}

    /// A TIME frame arrived (0x1012).
    fn on_time(&mut self, time: TimeOfDay) {
        let _ = time;
    }
}

/// A device with no hooks: the dictionary answers everything.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoApplication;

impl Application for NoApplication {}
