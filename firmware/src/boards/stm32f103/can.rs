//! bxCAN glue: set-up, the three CAN interrupts, error-passive and bus-off
//! detection, and what the CANopen task asks for: frames into the
//! mailboxes ([`send`]), acceptance filter banks ([`set_filters`]) and bit
//! timing ([`set_bit_timing`]).
//!
//! The interrupt handlers never touch the node: received frames go into
//! [`SHARED`]'s `rx` channel, controller events into its counters, and a
//! mailbox becoming empty wakes the CANopen task, which fills the
//! mailboxes from the node's queue itself ([`send`]).
#![allow(unsafe_code)]

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, Ordering};

use bxcan::Interrupts;
use canopen_core::node::AcceptedId;
use cortex_m::peripheral::DWT;
use critical_section::Mutex;
use stm32f1xx_hal::pac::{self, interrupt};

use super::{filters, mailbox};
use crate::app::{CanNode, SHARED};

/// The bxCAN instance as stm32f1xx-hal hands it to `bxcan`.
pub type Instance = stm32f1xx_hal::can::Can<pac::CAN>;

/// The controller, shared by the interrupts and the CANopen task (all at one priority).
static CAN: Mutex<RefCell<Option<bxcan::Can<Instance>>>> = Mutex::new(RefCell::new(None));
/// Set by the status-change interrupt when the controller went bus-off,
/// cleared by the TX-empty interrupt once it sends again.
static BUS_OFF: AtomicBool = AtomicBool::new(false);
/// Set by the status-change interrupt when the controller went error
/// passive, cleared by the TX-empty interrupt once it is error active again.
static PASSIVE: AtomicBool = AtomicBool::new(false);

/// Configures the controller and starts it: bit timing `btr`, automatic
/// retransmission, automatic bus-off recovery (ABOM), TX FIFO mode
/// (MCR.TXFP: the mailboxes leave in the order [`send`] fills them,
/// see [`mailbox`]), interrupts for TX-empty, FIFO 0 and bus-off. The filters stay as reset leaves them
/// (initialisation mode, no bank active: nothing is received) until the
/// CANopen task's first step programs the node's list ([`set_filters`]).
pub fn start(can: Instance, btr: u32) {
    let mut can = bxcan::Can::builder(can).set_bit_timing(btr).set_automatic_retransmit(true).leave_disabled();
    can.enable_interrupts(Interrupts::TRANSMIT_MAILBOX_EMPTY | Interrupts::FIFO0_MESSAGE_PENDING | Interrupts::FIFO0_OVERRUN);
    registers().mcr().modify(|_, w| w.txfp().set_bit());
    enable_bus_off_handling();
    // Leaves sleep mode; the controller joins the bus after 11 recessive
    // bits on its own, so there is nothing to wait for here.
    let _ = can.enable_non_blocking();
    with_can(|slot| *slot = Some(can));
}

fn with_can(f: impl FnOnce(&mut Option<bxcan::Can<Instance>>)) {
    critical_section::with(|cs| {
        if let Ok(mut can) = CAN.borrow(cs).try_borrow_mut() {
            f(&mut can);
        }
    });
}

/// Programs the filter banks for the node's identifiers (`filters`), every
/// bank into FIFO 0, the unused ones off. bxCAN stops receiving while its
/// filters are in initialisation mode (FMR.FINIT), a few microseconds
/// here: a frame that completes in that window is lost to this node.
///
/// Raw registers, not bxcan's `modify_filters`/`enable_bank`: measured on
/// every STM32 image, bxcan's API (a read-modify-write of four registers and
/// a bounds assertion per bank) costs about 1.5 KB of flash (unitek-ds
/// 32,732 → 34,260 B, ec5000 59,328 → 60,860 B) and no longer fits the
/// bmaxx4400 image in the flash region.
pub fn set_filters(ids: &[AcceptedId], complete: bool) {
    let can = registers();
    critical_section::with(|_| {
        can.fmr().modify(|_, w| w.finit().set_bit());
        // SAFETY: every bit pattern is valid in the filter registers
        // (RM0008 §24.9.4), and they are written only in filter
        // initialisation mode, with every bank inactive until the last write.
        unsafe {
            can.fa1r().write(|w| w.bits(0));
            can.ffa1r().write(|w| w.bits(0));
            let lists = filters::fits(ids, complete);
            let mut active = 0u32;
            if lists {
                for (bank, (fr1, fr2)) in can.fb_iter().zip(filters::list_banks(ids).map(filters::list_bank)) {
                    bank.fr1().write(|w| w.bits(fr1));
                    bank.fr2().write(|w| w.bits(fr2));
                    active = active << 1 | 1;
                }
            } else if let Some(bank) = can.fb_iter().next() {
                let (fr1, fr2) = filters::ALL_STANDARD;
                bank.fr1().write(|w| w.bits(fr1));
                bank.fr2().write(|w| w.bits(fr2));
                active = 1;
            }
            // List banks are 16-bit list mode; the fallback bank is one 32-bit mask.
            can.fm1r().write(|w| w.bits(if lists { active } else { 0 }));
            can.fs1r().write(|w| w.bits(if lists { 0 } else { active }));
            can.fa1r().write(|w| w.bits(active));
        }
        can.fmr().modify(|_, w| w.finit().clear_bit());
    });
}

/// How long [`set_bit_timing`] waits for initialisation mode: bxCAN enters
/// it only after the frame on the bus (RM0008 §24.4.1), at most about
/// 16 ms at 10 kbit/s; a bus that never goes idle must not hold the CPU.
pub const INIT_TIMEOUT_MS: u32 = 20;

/// Re-initialises the controller with bit timing `btr` (LSS "activate bit
/// timing": the node is silent then, and so should the bus be). It rejoins
/// the bus after 11 recessive bits at the new rate. If the controller does
/// not enter initialisation mode within `timeout_cycles` core cycles (the
/// bus never idle), the request is withdrawn and the controller stays at
/// its old bit rate: `Err`.
pub fn set_bit_timing(btr: u32, timeout_cycles: u32) -> Result<(), ()> {
    let can = registers();
    critical_section::with(|_| {
        // BTR is writable in initialisation mode only (RM0008 §24.9.2).
        can.mcr().modify(|_, w| w.inrq().set_bit());
        let start = DWT::cycle_count();
        while can.msr().read().inak().bit_is_clear() {
            if DWT::cycle_count().wrapping_sub(start) > timeout_cycles {
                can.mcr().modify(|_, w| w.inrq().clear_bit());
                return Err(());
            }
        }
        // Raw registers, not bxcan's `modify_config`: that waits for
        // initialisation mode without a bound (a busy bus would hold the CPU)
        // and leaves the controller in sleep mode for a blocking `enable`.
        // SAFETY: `btr` comes from `bit_timing::btr` (SJW, TS1, TS2, BRP
        // fields only); the mode bits (silent, loop back) are kept.
        can.btr().modify(|r, w| unsafe { w.bits((r.bits() & 0xC000_0000) | btr) });
        can.mcr().modify(|_, w| w.inrq().clear_bit());
        Ok(())
    })
}

/// The bxCAN registers bxcan does not cover (RM0008 §24.9.2).
fn registers() -> &'static pac::can::RegisterBlock {
    // SAFETY: the CAN register block is always mapped. The fields touched
    // through it are not used by bxcan after `start`; they are accessed in
    // `start` (before the interrupts are unmasked), and then IER.ERRIE/BOFIE/
    // EPVIE, MSR.ERRI and ESR only by the CAN interrupts (one priority, so
    // they never preempt each other), MCR.INRQ, BTR and the filter registers
    // FMR, FM1R, FS1R, FFA1R, FA1R, FiRx only by the CANopen task inside a
    // critical section. The receive FIFO (RF0R, its mailbox) is read only by
    // the FIFO 0 interrupt; the transmit mailboxes only by the CANopen task,
    // which reads TSR, while the TX-empty interrupt only writes TSR's RQCP
    // flags (write 1 to clear: mailbox contents, TME and CODE stay).
    unsafe { &*pac::CAN::ptr() }
}

/// ERRIE + BOFIE + EPVIE: the status-change interrupt fires on bus-off and
/// on error passive. (The automatic recovery, MCR.ABOM, is set by bxcan's
/// `enable_non_blocking`.)
fn enable_bus_off_handling() {
    registers().ier().modify(|_, w| w.bofie().set_bit().epvie().set_bit().errie().set_bit());
}

/// The CANopen task's transmitter: every empty mailbox gets the node's
/// next frame ([`mailbox::fill`]); in TX FIFO mode they leave in that
/// order, so a burst goes out back to back. When the mailboxes are full,
/// the TX-empty interrupt wakes the task again.
pub fn send(node: &mut dyn CanNode) {
    mailbox::fill(&mut TxMailboxes(registers()), || node.transmit());
}

/// The transmit mailboxes through their registers. The CANopen task is the
/// only writer; the TX-empty interrupt (which may preempt it) touches only
/// TSR's RQCP flags.
struct TxMailboxes(&'static pac::can::RegisterBlock);

impl mailbox::Mailboxes for TxMailboxes {
    fn empty(&self) -> Option<usize> {
        let tsr = self.0.tsr().read();
        // TSR.CODE names an empty mailbox when one is (RM0008 §24.9.2).
        tsr.tme_iter().any(|e| e.bit_is_set()).then(|| usize::from(tsr.code().bits()))
    }

    fn request(&mut self, i: usize, [tir, tdtr, tdlr, tdhr]: [u32; 4]) {
        let tx = self.0.tx(i.min(2));
        // SAFETY: every bit pattern is valid in a mailbox's identifier,
        // length and data registers (RM0008 §24.9.3); the mailbox is empty
        // (TSR.TMEx), so the controller does not read it until TXRQ.
        unsafe {
            tx.tdtr().write(|w| w.bits(tdtr));
            tx.tdlr().write(|w| w.bits(tdlr));
            tx.tdhr().write(|w| w.bits(tdhr));
            tx.tir().write(|w| w.bits(tir | mailbox::TXRQ));
        }
    }
}

/// A mailbox is empty: wake the CANopen task to fill it ([`send`]). Also
/// where the controller is seen back from bus-off and error passive, as a
/// frame it sent proves: with ABOM the controller retransmits its mailboxes
/// once it is back, so a frame that was waiting goes out and raises TX-empty.
#[interrupt]
fn USB_HP_CAN_TX() {
    if BUS_OFF.load(Ordering::Relaxed) || PASSIVE.load(Ordering::Relaxed) {
        let esr = registers().esr().read();
        if BUS_OFF.load(Ordering::Relaxed) && esr.boff().bit_is_clear() {
            BUS_OFF.store(false, Ordering::Relaxed);
            registers().ier().modify(|_, w| w.errie().set_bit());
            SHARED.controller.bus_off_recovered();
        }
        if PASSIVE.load(Ordering::Relaxed) && esr.epvf().bit_is_clear() {
            PASSIVE.store(false, Ordering::Relaxed);
            registers().ier().modify(|_, w| w.epvie().set_bit());
            SHARED.controller.set_error_passive(false);
        }
    }
    // Writing 1 clears each mailbox's request-completed flag (and its status bits).
    registers().tsr().write(|w| w.rqcp0().set_bit().rqcp1().set_bit().rqcp2().set_bit());
    SHARED.wake();
}

/// Received frames: everything in FIFO 0 goes to the CANopen task; a frame
/// the FIFO or the channel had no room for is counted.
#[interrupt]
fn USB_LP_CAN_RX0() {
    let can = registers();
    let rfr = can.rfr(0);
    loop {
        let status = rfr.read();
        if status.fovr().bit_is_set() {
            rfr.write(|w| w.fovr().clear());
            SHARED.rx_overrun();
        }
        if status.fmp().bits() == 0 {
            break;
        }
        let mb = can.rx(0);
        let frame = mailbox::received(mb.rir().read().bits(), mb.rdtr().read().bits(), mb.rdlr().read().bits(), mb.rdhr().read().bits());
        // Releases the output mailbox: the next frame of the FIFO moves up.
        rfr.write(|w| w.rfom().release());
        if frame.is_none_or(|f| SHARED.rx.try_send(f).is_err()) {
            SHARED.rx_overrun();
        }
    }
}

/// Status change: on error passive, report it and stop that source until
/// the TX-empty handler sees error active again (EPVF stays set until
/// then); on bus-off, note it and stop this interrupt until the TX-empty
/// handler sees the recovery (BOFF stays set until then).
#[interrupt]
fn CAN_SCE() {
    let can = registers();
    let esr = can.esr().read();
    if esr.epvf().bit_is_set() && !PASSIVE.load(Ordering::Relaxed) {
        can.ier().modify(|_, w| w.epvie().clear_bit());
        PASSIVE.store(true, Ordering::Relaxed);
        SHARED.controller.set_error_passive(true);
        SHARED.wake();
    }
    if esr.boff().bit_is_set() {
        can.ier().modify(|_, w| w.errie().clear_bit());
        BUS_OFF.store(true, Ordering::Relaxed);
    }
    // ERRI is cleared by writing 1.
    can.msr().write(|w| w.erri().set_bit());
}
