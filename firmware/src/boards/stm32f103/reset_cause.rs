//! Why the chip last reset, and what the node reports about it.
//!
//! RCC_CSR (RM0008 §7.3.10) holds the reset flags since the last clear:
//! power-on/power-down (POR), pin (NRST, also set by every internal reset),
//! software (SYSRESETREQ), independent and window watchdog, low power. They
//! are read and cleared (RMVF) once at start-up. A software reset the
//! firmware makes itself (after a panic or a HardFault), or a watchdog reset
//! it lets happen (a crystal that did not start), first leaves its reason in
//! two words of RAM that start-up does not zero (`.uninit`), guarded by a
//! magic value, so the next start-up tells them apart from a debugger's
//! reset or a hung executor.
//!
//! After a reset caused by a failure the node sends an EMCY once it is
//! running ([`ResetCause::emcy`]): 0x6100 "internal software" for the
//! watchdog, a panic and a HardFault, 0x5000 "device hardware" for the
//! crystal (CiA 301 table 21). The manufacturer-specific bytes are the cause
//! number (byte 3) and RCC_CSR bits 24–31 (byte 4); the node records both
//! in 0x1003 sub 1 (bits 16–23 and 24–31), so an SDO upload of 0x1003:01
//! reads the reset cause (docs/firmware.md, "Reset cause").

use canopen_core::wire::emcy::EmcyCode;

/// Why the chip reset (byte 3 of the EMCY, bits 16–23 of 0x1003 sub 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[repr(u8)]
pub enum ResetCause {
    /// Power-on or the NRST pin: nothing to report.
    PowerOrPin = 0,
    /// The independent watchdog: the CANopen executor stopped running.
    Watchdog = 1,
    /// A panic (logged with its location before the reset).
    Panic = 2,
    /// A HardFault (logged with its PC before the reset).
    HardFault = 3,
    /// The 8 MHz crystal did not start (logged; the watchdog reset the chip).
    Crystal = 4,
    /// A software reset the firmware did not ask for (a debugger), the
    /// window watchdog or a low-power reset: logged only.
    Other = 5,
}

/// RCC_CSR flags (RM0008 §7.3.10).
const PINRSTF: u32 = 1 << 26;
const PORRSTF: u32 = 1 << 27;
const SFTRSTF: u32 = 1 << 28;
const IWDGRSTF: u32 = 1 << 29;

/// The cause, from RCC_CSR and the reason the firmware left before the reset (if any).
pub fn classify(csr: u32, left: Option<u32>) -> ResetCause {
    let ours = |c: ResetCause| (left == Some(c as u32)).then_some(c);
    if csr & PORRSTF != 0 {
        ResetCause::PowerOrPin
    } else if csr & IWDGRSTF != 0 {
        ours(ResetCause::Crystal).unwrap_or(ResetCause::Watchdog)
    } else if csr & SFTRSTF != 0 {
        ours(ResetCause::Panic).or(ours(ResetCause::HardFault)).unwrap_or(ResetCause::Other)
    } else if csr & PINRSTF != 0 {
        ResetCause::PowerOrPin
    } else {
        ResetCause::Other
    }
}

impl ResetCause {
    /// The EMCY to send after boot-up (code, manufacturer bytes), if any:
    /// `restart` is the code of a restart the firmware did not ask for
    /// (watchdog, panic, HardFault): [`EmcyCode::INTERNAL_SOFTWARE`], unless the
    /// device's manual has its own (the EC5000's 0x6010, docs/devices/ec5000.md D53).
    pub fn emcy(self, flags: u8, restart: EmcyCode) -> Option<(EmcyCode, [u8; 5])> {
        let code = match self {
            ResetCause::Watchdog | ResetCause::Panic | ResetCause::HardFault => restart,
            ResetCause::Crystal => EmcyCode::DEVICE_HARDWARE,
            ResetCause::PowerOrPin | ResetCause::Other => return None,
        };
        Some((code, [self as u8, flags, 0, 0, 0]))
    }
}

#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
pub use mcu::{leave, take};

#[cfg(all(target_os = "none", feature = "board-stm32f103"))]
mod mcu {
    #![allow(unsafe_code)]

    use core::mem::MaybeUninit;
    use core::ptr::{addr_of, addr_of_mut};

    use stm32f1xx_hal::pac;

    use super::{ResetCause, classify};

    /// Marks the reason below as written by this firmware.
    const MAGIC: u32 = 0xC0DE_5E7A;

    /// The reason of a reset the firmware is about to make: magic, then cause.
    #[unsafe(link_section = ".uninit.RESET_REASON")]
    static mut REASON: MaybeUninit<[u32; 2]> = MaybeUninit::uninit();

    /// Leaves `cause` for the next start-up (then the caller resets, or lets the watchdog).
    pub fn leave(cause: ResetCause) {
        // SAFETY: a plain store to two static words of RAM; only start-up and
        // the fatal paths (panic, HardFault, crystal), which never return, touch them.
        unsafe { addr_of_mut!(REASON).cast::<[u32; 2]>().write_volatile([MAGIC, cause as u32]) }
    }

    /// Reads and clears the reset flags (and the reason left in RAM):
    /// the cause and RCC_CSR bits 24–31.
    pub fn take(rcc: &pac::RCC) -> (ResetCause, u8) {
        let csr = rcc.csr().read().bits();
        // SAFETY: as in `leave`; read once at start-up before any writer runs.
        let [magic, left] = unsafe { addr_of!(REASON).cast::<[u32; 2]>().read_volatile() };
        // SAFETY: as above.
        unsafe { addr_of_mut!(REASON).cast::<[u32; 2]>().write_volatile([0, 0]) };
        rcc.csr().modify(|_, w| w.rmvf().set_bit());
        (classify(csr, (magic == MAGIC).then_some(left)), (csr >> 24) as u8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn causes_from_the_flags_and_the_reason_left() {
        let pin = PINRSTF;
        // Power-on sets POR and PIN; whatever RAM holds then is noise.
        assert_eq!(classify(PORRSTF | pin, Some(2)), ResetCause::PowerOrPin);
        assert_eq!(classify(pin, None), ResetCause::PowerOrPin, "NRST");
        // Every internal reset also pulses NRST (PINRSTF).
        assert_eq!(classify(IWDGRSTF | pin, None), ResetCause::Watchdog);
        assert_eq!(classify(IWDGRSTF | pin, Some(ResetCause::Crystal as u32)), ResetCause::Crystal);
        assert_eq!(classify(IWDGRSTF | pin, Some(ResetCause::Panic as u32)), ResetCause::Watchdog);
        assert_eq!(classify(SFTRSTF | pin, Some(ResetCause::Panic as u32)), ResetCause::Panic);
        assert_eq!(classify(SFTRSTF | pin, Some(ResetCause::HardFault as u32)), ResetCause::HardFault);
        assert_eq!(classify(SFTRSTF | pin, None), ResetCause::Other, "a debugger's reset");
        assert_eq!(classify(SFTRSTF | pin, Some(ResetCause::Crystal as u32)), ResetCause::Other);
        assert_eq!(classify(1 << 31, None), ResetCause::Other, "low-power reset");
    }

    #[test]
    fn emcy_codes_and_what_0x1003_records() {
        assert_eq!(ResetCause::Watchdog.emcy(0x24, EmcyCode::INTERNAL_SOFTWARE), Some((EmcyCode(0x6100), [1, 0x24, 0, 0, 0])));
        assert_eq!(ResetCause::Panic.emcy(0x14, EmcyCode::INTERNAL_SOFTWARE), Some((EmcyCode(0x6100), [2, 0x14, 0, 0, 0])));
        assert_eq!(ResetCause::HardFault.emcy(0x14, EmcyCode::INTERNAL_SOFTWARE), Some((EmcyCode(0x6100), [3, 0x14, 0, 0, 0])));
        assert_eq!(ResetCause::Crystal.emcy(0x24, EmcyCode::INTERNAL_SOFTWARE), Some((EmcyCode(0x5000), [4, 0x24, 0, 0, 0])));
        assert_eq!(ResetCause::PowerOrPin.emcy(0x0C, EmcyCode::INTERNAL_SOFTWARE), None);
        assert_eq!(ResetCause::Other.emcy(0x14, EmcyCode::INTERNAL_SOFTWARE), None);
    }
}
