//! UART0 of the lm3s6965 (an ARM PL011, as QEMU emulates it): blocking
//! transmit, and the register access the board's receive interrupt needs.
//!
//! Register offsets and bits: PL011 TRM (ARM DDI 0183) §3.2, which the
//! lm3s6965 datasheet's UART chapter follows. The FIFOs stay off, so every
//! received byte raises the RX interrupt. Instead of dropping bytes when it
//! has no room, the board masks the RX interrupt ([`pause_rx`]); QEMU then
//! leaves the rest in the TCP socket until [`resume_rx`].
#![allow(unsafe_code)]

use cortex_m::peripheral::NVIC;
use lm3s6965::Interrupt;

/// UART0 base address (lm3s6965 memory map).
const BASE: usize = 0x4000_C000;
/// Data register.
const DR: usize = 0x00;
/// Flag register.
const FR: usize = 0x18;
/// Line control: 0x60 = 8 data bits (WLEN = 0b11), no parity, one stop bit, FIFOs off.
const LCRH: usize = 0x2C;
const LCRH_8N1: u32 = 0x60;
/// Control: 0x301 = UARTEN | TXE | RXE.
const CTL: usize = 0x30;
const CTL_ENABLE: u32 = 0x301;
/// Interrupt mask set/clear.
const IM: usize = 0x38;
/// Interrupt clear.
const ICR: usize = 0x44;
/// FR: receive FIFO (holding register) empty.
const FR_RXFE: u32 = 1 << 4;
/// FR: transmit FIFO (holding register) full.
const FR_TXFF: u32 = 1 << 5;
/// IM/ICR: receive interrupt.
const INT_RX: u32 = 1 << 4;

fn read(offset: usize) -> u32 {
    // SAFETY: BASE + offset is one of the 32-bit aligned UART0 registers
    // named above; reading them has no side effect except DR, which only the
    // UART0 handler reads.
    unsafe { core::ptr::read_volatile((BASE + offset) as *const u32) }
}

fn write(offset: usize, value: u32) {
    // SAFETY: as in `read`; the board owns UART0, and the read-modify-writes
    // of IM happen inside critical sections.
    unsafe { core::ptr::write_volatile((BASE + offset) as *mut u32, value) }
}

/// Sets the UART up (8N1; QEMU ignores the baud rate) and enables its
/// interrupt, whose handler the board defines.
pub fn init() {
    write(LCRH, LCRH_8N1);
    write(IM, INT_RX);
    write(CTL, CTL_ENABLE);
    // SAFETY: the board's UART0 handler is linked in and touches only UART0
    // and state behind critical sections.
    unsafe { NVIC::unmask(Interrupt::UART0) };
}

/// Sends `bytes`, waiting while the transmit register is full.
pub fn write_all(bytes: &[u8]) {
    for &b in bytes {
        while read(FR) & FR_TXFF != 0 {}
        write(DR, u32::from(b));
    }
}

/// The next received byte, if one is waiting.
pub fn read_byte() -> Option<u8> {
    (read(FR) & FR_RXFE == 0).then(|| read(DR) as u8)
}

/// Acknowledges the RX interrupt (the handler calls it last).
pub fn clear_rx_interrupt() {
    write(ICR, INT_RX);
}

/// Masks the RX interrupt while the receiver has no room; QEMU keeps what
/// follows in the TCP socket.
pub fn pause_rx() {
    critical_section::with(|_| write(IM, read(IM) & !INT_RX));
}

/// Unmasks the RX interrupt again.
pub fn resume_rx() {
    critical_section::with(|_| write(IM, read(IM) | INT_RX));
}
