//! The receive interrupts' own work for one frame, minus the controller
//! access, as the boards do it:
//!
//! - QEMU (`firmware/src/boards/qemu/board.rs`, `UART0`): one interrupt per
//!   received byte (the PL011's FIFO is off); each feeds the SLCAN decoder,
//!   and the line's CR decodes the frame, answers it, checks for the exit
//!   frame and pushes the frame into the CANopen task's channel. [`slcan_line`]
//!   runs the same handler body with the UART's data register replaced by the
//!   line's bytes and the answer's UART writes left out.
//! - STM32F103 (`boards/stm32f103/can.rs`, `USB_LP_CAN_RX0`): the frame read
//!   from FIFO 0 is converted from bxcan's frame type and pushed into the
//!   channel. [`bxcan_frame`] does the conversion and the push.
//!
//! Both use a channel of the firmware's type and depth (`app::SHARED.rx`).

use core::cell::RefCell;
use core::hint::black_box;

use canopen_core::frame::CanFrame;
use critical_section::Mutex;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel as FrameChannel;
use firmware::app::{RX_QUEUE, convert_frame};
use firmware::boards::qemu::exit_request;
use firmware::boards::qemu::slcan::reply;
use firmware::slcan::{BEL, ChannelState, Command, Decoder};

use crate::clock::{Clock, Tally};

/// The CANopen task's receive channel, as `app::Shared::rx`.
pub type Rx = FrameChannel<CriticalSectionRawMutex, CanFrame, RX_QUEUE>;

/// The SLCAN adapter state of the QEMU board's UART0 handler.
struct Adapter {
    decoder: Decoder,
    channel: ChannelState,
}

static ADAPTER: Mutex<RefCell<Adapter>> = Mutex::new(RefCell::new(Adapter { decoder: Decoder::new(), channel: ChannelState::Open }));

impl Adapter {
    /// `board.rs`'s `Adapter::on_byte` without the UART writes of the answer.
    fn on_byte(&mut self, byte: u8, rx: &Rx) -> Option<&'static [u8]> {
        let result = self.decoder.push(byte)?;
        let Ok(command) = result else { return Some(&[BEL]) };
        let (next, answer) = reply(self.channel, &command);
        self.channel = next;
        if let Command::Transmit(frame) = command
            && answer != [BEL]
        {
            if exit_request(&frame).is_some() {
                return None;
            }
            // The firmware counts a full channel as an overrun; the bench
            // empties it after every line, so it is never full here.
            let _ = rx.try_send(frame);
        }
        Some(answer)
    }
}

/// The UART0 handler's body for one received byte.
#[inline(never)]
fn uart0_interrupt(byte: u8, rx: &Rx) -> Option<&'static [u8]> {
    critical_section::with(|cs| {
        let mut adapter = ADAPTER.borrow(cs).try_borrow_mut().ok()?;
        let mut data = Some(byte);
        let mut answer = None;
        while !rx.is_full() {
            // The data register, read once per interrupt.
            let Some(byte) = data.take() else { break };
            answer = adapter.on_byte(byte, rx);
        }
        answer
    })
}

/// Times the QEMU receive path for one frame sent as `line` (an SLCAN line
/// with its CR): each byte but the last into `bytes`, the CR into `cr`.
/// Fails unless exactly `frame` reached the channel and the adapter answered `z`.
pub fn slcan_line(
    clock: &mut Clock,
    bytes: &mut Tally,
    cr: &mut Tally,
    rx: &Rx,
    line: &[u8],
    frame: &CanFrame,
) -> Result<(), &'static str> {
    let mut answer = None;
    for (i, &byte) in line.iter().enumerate() {
        let tally = if i + 1 == line.len() { &mut *cr } else { &mut *bytes };
        let byte = black_box(byte);
        answer = black_box(clock.time(tally, || uart0_interrupt(byte, rx)));
    }
    let received = rx.try_receive().ok();
    if received.as_ref() != Some(frame) || rx.try_receive().is_ok() || answer != Some(b"z\r") {
        return Err("SLCAN line: the frame did not reach the channel");
    }
    Ok(())
}

/// Times the STM32 receive path after the FIFO read into `tally`:
/// conversion from bxcan's frame and the push. Fails unless `frame` reached the channel.
pub fn bxcan_frame(clock: &mut Clock, tally: &mut Tally, rx: &Rx, frame: &CanFrame) -> Result<(), &'static str> {
    let from_fifo: bxcan::Frame = black_box(convert_frame(frame).ok_or("no bxcan frame")?);
    let delivered = clock.time(tally, || convert_frame::<bxcan::Frame, CanFrame>(&from_fifo).is_some_and(|f| rx.try_send(f).is_ok()));
    if !delivered || rx.try_receive().ok().as_ref() != Some(frame) {
        return Err("bxCAN: the frame did not reach the channel");
    }
    Ok(())
}
