//! Why the chip last reset, and what the node reports about it.
//!
//! RCC_CSR (RM0008 §7.3.10) holds the reset flags since the last clear:
//! power-on, pin (NRST), software (SYSRESETREQ), independent and window
//! watchdog, low power. They are read and cleared (RMVF) once at start-up.
//! A software reset the firmware makes itself (after a panic, a HardFault
//! or a crystal that did not start) first leaves its reason in a word of
//! RAM that start-up does not zero (`.uninit`), guarded by a magic value, so
//! the next start-up tells them apart from a debugger's reset.
//!
//! After a reset caused by a failure the node sends an EMCY once it is
//! running ([`ResetCause::emcy`]): 0x6100 "internal software" for the
//! watchdog, a panic and a HardFault, 0x5000 "device hardware" for the
//! crystal. The manufacturer-specific bytes are the cause number (byte 3)
//! and RCC_CSR bits 24–31 (byte 4); the node records both in 0x1003 sub 1
//! (bits 16–23 and 24–31), so an SDO upload of 0x1003:01 reads the reset
//! cause (docs/firmware.md, "Reset cause").
#![allow(unsafe_code)]

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use stm32f1xx_hal::pac;

/// Why the chip reset (byte 3 of the EMCY, bits 16–23 of 0x1003 sub 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
#[repr(u8)]
pub enum ResetCause {
    /// Power-on, brown-out or the NRST pin: nothing to report.
    PowerOrPin = 0,
    /// The independent watchdog: the CANopen executor stopped running.
    Watchdog = 1,
    /// A panic (logged with its location before the reset).
    Panic = 2,
    /// A HardFault (logged with its PC before the reset).
    HardFault = 3,
    /// The 8 MHz crystal did not start within [`HSE_TIMEOUT_MS`](super::board) ms.
    Crystal = 4,
    /// A software reset the firmware did not ask for (a debugger), or the
    /// window watchdog or low-power reset: logged only.
    Other = 5,
}

/// EMCY "internal software" (CiA 301 table 21).
const INTERNAL_SOFTWARE: u16 = 0x6100;
/// EMCY "device hardware" (CiA 301 table 21).
const DEVICE_HARDWARE: u16 = 0x5000;

/// Marks the word below as written by this firmware.
const MAGIC: u32 = 0xC0DE_5E7A;

/// The reason of a reset the firmware is about to make: magic, then cause.
#[unsafe(link_section = ".uninit.RESET_REASON")]
static mut REASON: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();

/// Leaves `cause` for the next start-up (then the caller resets).
pub fn leave(cause: ResetCause) {
    // SAFETY: a plain store to a static word of RAM; only start-up and the
    // fatal paths (panic, HardFault, crystal), which never return, touch it.
    unsafe { addr_of_mut!(REASON).cast::<[u32; 2]>().write_volatile([MAGIC, cause as u32]) }
}

/// Reads and clears the reset flags (and the reason left in RAM).
pub fn take(rcc: &pac::RCC) -> (ResetCause, u8) {
    let csr = rcc.csr().read();
    let flags = (csr.bits() >> 24) as u8;
    // SAFETY: as in `leave`; read once at start-up before any writer runs.
    let [magic, left] = unsafe { addr_of!(REASON).cast::<[u32; 2]>().read_volatile() };
    // SAFETY: as above.
    unsafe { addr_of_mut!(REASON).cast::<[u32; 2]>().write_volatile([0, 0]) };
    rcc.csr().modify(|_, w| w.rmvf().set_bit());
    let ours = |c: ResetCause| (magic == MAGIC && left == c as u32).then_some(c);
    let cause = if csr.porrstf().bit_is_set() {
        ResetCause::PowerOrPin
    } else if csr.iwdgrstf().bit_is_set() {
        // The crystal wait ends by letting the watchdog reset the chip.
        ours(ResetCause::Crystal).unwrap_or(ResetCause::Watchdog)
    } else if csr.sftrstf().bit_is_set() {
        ours(ResetCause::Panic).or(ours(ResetCause::HardFault)).unwrap_or(ResetCause::Other)
    } else if csr.pinrstf().bit_is_set() {
        ResetCause::PowerOrPin
    } else {
        ResetCause::Other
    };
    (cause, flags)
}

impl ResetCause {
    /// The EMCY to send after boot-up (code, manufacturer bytes), if any.
    pub fn emcy(self, flags: u8) -> Option<(u16, [u8; 5])> {
        let code = match self {
            ResetCause::Watchdog | ResetCause::Panic | ResetCause::HardFault => INTERNAL_SOFTWARE,
            ResetCause::Crystal => DEVICE_HARDWARE,
            ResetCause::PowerOrPin | ResetCause::Other => return None,
        };
        Some((code, [self as u8, flags, 0, 0, 0]))
    }
}
