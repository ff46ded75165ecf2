//! One receive PDO. CiA 301 v4.2 §7.2.2; objects 0x1400–0x15FF
//! (communication) and 0x1600–0x17FF (mapping).
//!
//! - Transmission types 0..=240 (synchronous): the data of the last RPDO
//!   received inside the synchronous window is written on the next SYNC;
//!   an RPDO received after the window closed is discarded (0x1007).
//! - 254, 255 (event-driven): the data is written at once.
//! - Length (§7.2.2.2): fewer bytes than mapped → not processed, EMCY 0x8210;
//!   more bytes → the mapped bytes are processed and EMCY 0x8220 raised, as
//!   CANopenNode and Lely do. Either error ends with the next RPDO of the
//!   right length. Each frame of a wrong length is also told to the device
//!   (a drive's own fault on it).
//! - Event timer (sub 5, ms): deadline monitoring, armed by the first RPDO
//!   received; expiry raises EMCY 0x8250, the next RPDO ends it.

use super::config::{Change, Config};
use super::map::{MAX_LEN, Mapping};
use super::{CommParams, PdoTx};
use crate::time::{At, at_by, later, shift_opt};
use crate::wire::emcy::EmcyCode;

/// The state of one RPDO.
// In this order (`repr(C)`): the flags and the timer the frame's path
// tests first, then the parameters (see [`super::tpdo::Tpdo`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rpdo {
    /// `buffered` holds data for the next SYNC (a flag, not an `Option`:
    /// the buffer is written in place).
    has_buffered: bool,
    /// EMCY 0x8250 is raised.
    timed_out: bool,
    /// EMCY 0x8210 or 0x8220 raised and not yet ended.
    /// [`EmcyCode::NO_ERROR`] when none is (a code, not an `Option`: one
    /// compare on the frame's path).
    length_error: EmcyCode,
    /// Deadline of the event timer, armed by each RPDO received.
    timeout_at: Option<At>,
    /// Parameters and mapping ([`Config`]).
    pub(super) config: Config,
    /// Synchronous data waiting for the next SYNC.
    buffered: [u8; MAX_LEN],
}

impl Default for Rpdo {
    fn default() -> Self {
        Rpdo { config: Config::DEFAULT, ..Rpdo::UNCONFIGURED }
    }
}

impl Rpdo {
    /// Before the first [`super::Pdos::configure`]: all zero bits
    /// ([`crate::node`]), an empty mapping, so it listens to nothing.
    pub(super) const UNCONFIGURED: Rpdo = Rpdo {
        config: Config::UNCONFIGURED,
        buffered: [0; MAX_LEN],
        has_buffered: false,
        timeout_at: None,
        timed_out: false,
        length_error: EmcyCode::NO_ERROR,
    };

    /// The cached communication parameters.
    pub fn params(&self) -> &CommParams {
        &self.config.params
    }

    /// The resolved mapping, or `None` if the configured one is invalid.
    pub fn mapping(&self) -> Option<&Mapping> {
        (!self.config.unresolved).then_some(&self.config.mapping)
    }

    /// The CAN-ID it listens to: `Some` when the COB-ID is valid and a
    /// non-empty mapping resolved (a mapping of sub 0 = 0 disables the PDO).
    pub fn cob_id(&self) -> Option<u16> {
        self.config.cob_id()
    }

    /// Its `Pdos::rx_keys` entry: `super::NO_KEY` while it listens to
    /// nothing, else the key ([`super::frame_key`]) of a frame of its
    /// mapping's length on its CAN-ID, which it takes the plain way while
    /// it is event-driven, has no event timer and no length or timeout
    /// error is raised (else with `super::NOT_PLAIN`). For such a frame
    /// [`Rpdo::on_frame`] writes the data and tells, and changes nothing
    /// else (its event timer is off: `timeout_at` is `None` already).
    pub(super) fn rx_key(&self) -> u32 {
        let Some(id) = self.cob_id() else { return super::NO_KEY };
        let key = super::frame_key(id, self.config.mapping.len());
        if self.config.params.is_synchronous()
            || self.config.params.event_timer() != 0
            || self.length_error != EmcyCode::NO_ERROR
            || self.timed_out
        {
            return key | super::NOT_PLAIN;
        }
        key
    }

    /// Whether synchronous data waits for the next SYNC.
    pub fn has_buffered(&self) -> bool {
        self.has_buffered
    }

    /// Entering Operational (or a new configuration): nothing buffered, the
    /// event timer waits for the first RPDO. Raised errors stay until a
    /// good RPDO ends them, so the node's error state stays consistent.
    pub(super) fn restart(&mut self) {
        self.has_buffered = false;
        self.timeout_at = None;
    }

    /// Acts on what a download or the configuration changed
    /// ([`Config::change`]), in `Pdos::parameters_changed`'s walk.
    pub(super) fn act(&mut self) {
        match core::mem::take(&mut self.config.change) {
            Change::None => {}
            Change::Restart => self.restart(),
            Change::Timer => self.disarm_timer(),
        }
    }

    /// The event timer was rewritten: it restarts with the next RPDO.
    pub(super) fn disarm_timer(&mut self) {
        self.timeout_at = None;
    }

    /// An RPDO frame. `window_open`: the synchronous window since the last
    /// SYNC is still open. True if it wrote its data into the dictionary now.
    pub(super) fn on_frame(&mut self, n: usize, now: At, data: &[u8], window_open: bool, image: &mut [u8], out: &mut impl PdoTx) -> bool {
        // Only a valid RPDO takes frames (`Pdos::rx_keys`), and its mapping is not empty.
        let len = self.config.mapping.len();
        // The right length with no error to end (the common frame): two compares.
        if data.len() != len || self.length_error != EmcyCode::NO_ERROR {
            let error = match data.len().cmp(&len) {
                core::cmp::Ordering::Less => EmcyCode::PDO_LENGTH,
                core::cmp::Ordering::Greater => EmcyCode::PDO_LENGTH_EXCEEDED,
                core::cmp::Ordering::Equal => EmcyCode::NO_ERROR,
            };
            if error != self.length_error {
                if self.length_error != EmcyCode::NO_ERROR {
                    out.error_cleared(n, self.length_error);
                }
                self.length_error = error;
            }
            // Each frame of a wrong length (its EMCY is sent once); a short one is not processed.
            if error != EmcyCode::NO_ERROR {
                out.error(n, error);
                if data.len() < len {
                    return false;
                }
            }
        }
        if self.timed_out {
            self.timed_out = false;
            out.error_cleared(n, EmcyCode::RPDO_TIMEOUT);
        }
        let timer = self.config.params.event_timer();
        self.timeout_at = (timer != 0).then(|| later(now, timer));
        if self.config.params.is_synchronous() {
            if window_open {
                // The mapped bytes (`apply` reads no more).
                if let (Some(dst), Some(src)) = (self.buffered.get_mut(..len), data.get(..len)) {
                    dst.copy_from_slice(src);
                }
                self.has_buffered = true;
            }
            false
        } else {
            self.config.mapping.apply(image, data);
            out.received(n);
            true
        }
    }

    /// A SYNC: buffered synchronous data goes into the dictionary.
    pub(super) fn on_sync(&mut self, n: usize, image: &mut [u8], out: &mut impl PdoTx) {
        if core::mem::take(&mut self.has_buffered) {
            self.config.mapping.apply(image, &self.buffered);
            out.received(n);
        }
    }

    /// The event timer.
    pub(super) fn poll(&mut self, n: usize, now: At, out: &mut impl PdoTx) {
        if self.timeout_at.is_some_and(|t| now >= t) {
            self.timeout_at = None;
            self.timed_out = true;
            out.error(n, EmcyCode::RPDO_TIMEOUT);
        }
    }

    /// When the RPDO times out, if its timer runs. Only a valid RPDO
    /// with a mapping takes frames, and only a frame arms the timer; a new
    /// COB-ID or mapping restarts the RPDO, which disarms it: a timer runs
    /// only while the RPDO is valid.
    pub(super) fn timeout_at(&self) -> Option<At> {
        self.timeout_at
    }

    /// The epoch moved by `by` µs.
    pub(super) fn shift(&mut self, by: u64) {
        shift_opt(&mut self.timeout_at, at_by(by));
    }
}
