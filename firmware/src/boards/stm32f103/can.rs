//! bxCAN glue: set-up, the three CAN interrupts, and bus-off detection.
//!
//! The interrupt handlers only move frames and count events; every frame
//! passes through [`SHARED`] (received ones in `rx`, sent ones from the
//! node's queue), so the CANopen logic stays in the core and in `app`.
#![allow(unsafe_code)]

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, Ordering};

use bxcan::filter::Mask32;
use bxcan::{Fifo, Interrupts, Rx0, StandardId, Tx};
use canopen_core::frame::CanFrame;
use critical_section::Mutex;
use stm32f1xx_hal::pac::{self, interrupt};

use crate::app::{SHARED, convert_frame};

/// The bxCAN instance as stm32f1xx-hal hands it to `bxcan`.
pub type Instance = stm32f1xx_hal::can::Can<pac::CAN>;

static TX: Mutex<RefCell<Option<Tx<Instance>>>> = Mutex::new(RefCell::new(None));
static RX: Mutex<RefCell<Option<Rx0<Instance>>>> = Mutex::new(RefCell::new(None));
/// Set by the status-change interrupt when the controller went bus-off,
/// cleared by the TX-empty interrupt once it sends again.
static BUS_OFF: AtomicBool = AtomicBool::new(false);

/// Configures the controller and starts it: bit timing `btr`, every 11-bit
/// frame into FIFO 0, automatic retransmission, automatic bus-off recovery
/// (ABOM), interrupts for TX-empty, FIFO 0 and bus-off.
pub fn start(can: Instance, btr: u32) {
    let mut can = bxcan::Can::builder(can).set_bit_timing(btr).set_automatic_retransmit(true).leave_disabled();
    // Accept-all for standard identifiers; 29-bit frames never reach the node.
    can.modify_filters().enable_bank(0, Fifo::Fifo0, Mask32::frames_with_std_id(StandardId::ZERO, StandardId::ZERO));
    can.enable_interrupts(Interrupts::TRANSMIT_MAILBOX_EMPTY | Interrupts::FIFO0_MESSAGE_PENDING | Interrupts::FIFO0_OVERRUN);
    enable_bus_off_handling();
    // Leaves sleep mode; the controller joins the bus after 11 recessive
    // bits on its own, so there is nothing to wait for here.
    let _ = can.enable_non_blocking();
    let (tx, rx, _) = can.split();
    critical_section::with(|cs| {
        if let (Ok(mut tx_slot), Ok(mut rx_slot)) = (TX.borrow(cs).try_borrow_mut(), RX.borrow(cs).try_borrow_mut()) {
            *tx_slot = Some(tx);
            *rx_slot = Some(rx);
        }
    });
}

/// The bxCAN registers bxcan does not cover (RM0008 §24.9.2).
fn registers() -> &'static pac::can::RegisterBlock {
    // SAFETY: the CAN register block is always mapped. The fields touched
    // through it (IER.ERRIE/BOFIE, MSR.ERRI, ESR) are not used by
    // bxcan after `start`; they are accessed in `start` (before the
    // interrupts are unmasked) and in the CAN interrupts, which share one
    // priority and so never preempt each other.
    unsafe { &*pac::CAN::ptr() }
}

/// ERRIE + BOFIE: the status-change interrupt fires on bus-off. (The
/// automatic recovery, MCR.ABOM, is set by bxcan's `enable_non_blocking`.)
fn enable_bus_off_handling() {
    registers().ier().modify(|_, w| w.bofie().set_bit().errie().set_bit());
}

/// Frames for the mailboxes: on each TX-empty interrupt (and when the
/// CANopen task pends it), the node's queue goes into the mailboxes in
/// priority order until they are full. After bus-off, the first of these
/// interrupts with BOFF clear reports the recovery: with ABOM the
/// controller retransmits its mailboxes once it is back, so a frame that
/// was waiting goes out and raises TX-empty.
#[interrupt]
fn USB_HP_CAN_TX() {
    if BUS_OFF.load(Ordering::Relaxed) && registers().esr().read().boff().bit_is_clear() {
        BUS_OFF.store(false, Ordering::Relaxed);
        registers().ier().modify(|_, w| w.errie().set_bit());
        SHARED.bus_off_recovered();
    }
    critical_section::with(|cs| {
        let Ok(mut tx) = TX.borrow(cs).try_borrow_mut() else { return };
        let Some(tx) = tx.as_mut() else { return };
        tx.clear_interrupt_flags();
        SHARED.with_node(|node| {
            while let Some(frame) = node.transmit() {
                let Some(out) = convert_frame::<CanFrame, bxcan::Frame>(&frame) else { continue };
                match tx.transmit(&out) {
                    Ok(status) => {
                        // A lower-priority frame taken out of its mailbox: it goes out first next time.
                        if let Some(back) = status.dequeued_frame().and_then(convert_frame::<bxcan::Frame, CanFrame>) {
                            node.requeue(back);
                        }
                    }
                    Err(_) => {
                        // Mailboxes full (or holding this identifier): wait for TX-empty.
                        node.requeue(frame);
                        break;
                    }
                }
            }
        });
    });
}

/// Received frames: everything in FIFO 0 goes to the CANopen task; a frame
/// the FIFO or the channel had no room for is counted.
#[interrupt]
fn USB_LP_CAN_RX0() {
    critical_section::with(|cs| {
        let Ok(mut rx) = RX.borrow(cs).try_borrow_mut() else { return };
        let Some(rx) = rx.as_mut() else { return };
        loop {
            match rx.receive() {
                Ok(frame) => {
                    let delivered = convert_frame::<bxcan::Frame, CanFrame>(&frame).is_some_and(|f| SHARED.rx.try_send(f).is_ok());
                    if !delivered {
                        SHARED.rx_overrun();
                    }
                }
                Err(nb::Error::Other(_overrun)) => SHARED.rx_overrun(),
                Err(nb::Error::WouldBlock) => break,
            }
        }
    });
}

/// Status change: on bus-off, note it and stop this interrupt until the
/// TX-empty handler sees the recovery (BOFF stays set until then).
#[interrupt]
fn CAN_SCE() {
    let can = registers();
    if can.esr().read().boff().bit_is_set() {
        can.ier().modify(|_, w| w.errie().clear_bit());
        BUS_OFF.store(true, Ordering::Relaxed);
    }
    // ERRI is cleared by writing 1.
    can.msr().write(|w| w.erri().set_bit());
}
