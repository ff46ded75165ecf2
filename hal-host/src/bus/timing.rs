//! The bit-level model of a classic CAN frame (ISO 11898-1:2015 §10.4):
//! which bits a frame puts on the wire, its CRC-15, its stuff bits, and how
//! long all of it takes at a given bit rate.
//!
//! Layout of a data or remote frame, in order:
//! - standard (11-bit id): SOF, 11 id bits, RTR, IDE (dominant), r0, 4 DLC bits;
//! - extended (29-bit id): SOF, 11 base id bits, SRR (recessive), IDE
//!   (recessive), 18 id-extension bits, RTR, r1, r0, 4 DLC bits;
//! - then the data bytes (none for a remote frame), the 15-bit CRC sequence,
//!   all of the above bit-stuffed (§10.5: after five equal bits a complementary
//!   bit is inserted, stuff bits count towards the next run, and a stuff bit
//!   also follows the last CRC bit if it ends a run of five);
//! - then, unstuffed: CRC delimiter, ACK slot, ACK delimiter, 7 EOF bits, and
//!   the 3-bit intermission before the next SOF.

use canopen_core::frame::CanFrame;
use core::num::NonZeroU32;
use embedded_can::Frame;

/// Bits after the CRC sequence up to the end of EOF: CRC delimiter, ACK slot,
/// ACK delimiter, 7 EOF bits.
pub const TRAILER_BITS: u32 = 1 + 1 + 1 + 7;
/// Bits of intermission between frames (ISO 11898-1 §10.4.6.2).
pub const INTERMISSION_BITS: u32 = 3;
/// Bits of an error frame: a 6-bit error flag and an 8-bit error delimiter
/// (§10.4.4). Superposed flags of several nodes are modelled as one.
pub const ERROR_FRAME_BITS: u32 = 6 + 8;
/// Bits of a corrupted frame that still go out before the error flag: the
/// receivers detect the CRC error and start their flag after the ACK
/// delimiter (§10.11: CRC delimiter, ACK slot, ACK delimiter).
pub const CRC_ERROR_DETECT_BITS: u32 = 3;
/// Recessive bits that end every frame and every error frame (ACK delimiter,
/// EOF and intermission, or error delimiter and intermission). Bus-off
/// recovery counts runs of 11 recessive bits.
pub const RECESSIVE_TAIL_BITS: u32 = 11;

/// A CAN bit rate in bit/s, never zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BitRate(NonZeroU32);

impl BitRate {
    /// 1 Mbit/s.
    pub const MBIT_1: BitRate = BitRate::from_const(1_000_000);
    /// 800 kbit/s.
    pub const KBIT_800: BitRate = BitRate::from_const(800_000);
    /// 500 kbit/s.
    pub const KBIT_500: BitRate = BitRate::from_const(500_000);
    /// 250 kbit/s.
    pub const KBIT_250: BitRate = BitRate::from_const(250_000);
    /// 125 kbit/s.
    pub const KBIT_125: BitRate = BitRate::from_const(125_000);
    /// 100 kbit/s (not in the CiA 301 table, but a Lawicel `S3`).
    pub const KBIT_100: BitRate = BitRate::from_const(100_000);
    /// 50 kbit/s.
    pub const KBIT_50: BitRate = BitRate::from_const(50_000);
    /// 20 kbit/s.
    pub const KBIT_20: BitRate = BitRate::from_const(20_000);
    /// 10 kbit/s.
    pub const KBIT_10: BitRate = BitRate::from_const(10_000);

    const fn from_const(bps: u32) -> BitRate {
        match NonZeroU32::new(bps) {
            Some(n) => BitRate(n),
            None => BitRate(NonZeroU32::MIN),
        }
    }

    /// A bit rate of `bps` bit/s; `None` for zero.
    pub const fn new(bps: u32) -> Option<BitRate> {
        match NonZeroU32::new(bps) {
            Some(n) => Some(BitRate(n)),
            None => None,
        }
    }

    /// The rate in bit/s.
    pub const fn bps(self) -> u32 {
        self.0.get()
    }

    /// The rate of a bit timing table index as LSS uses it (CiA 305 §6.4.3
    /// table 1: 0 = 1000 kbit/s, 1 = 800, 2 = 500, 3 = 250, 4 = 125,
    /// 5 reserved, 6 = 50, 7 = 20, 8 = 10); `None` for anything else.
    pub const fn from_cia_index(index: u8) -> Option<BitRate> {
        match index {
            0 => Some(BitRate::MBIT_1),
            1 => Some(BitRate::KBIT_800),
            2 => Some(BitRate::KBIT_500),
            3 => Some(BitRate::KBIT_250),
            4 => Some(BitRate::KBIT_125),
            6 => Some(BitRate::KBIT_50),
            7 => Some(BitRate::KBIT_20),
            8 => Some(BitRate::KBIT_10),
            _ => None,
        }
    }

    /// Nanoseconds taken by `bits` bits, rounded up (exact for every rate
    /// that divides 10⁹, which includes all of the CiA 301 table).
    pub const fn bits_to_ns(self, bits: u64) -> u64 {
        let bps = self.0.get() as u128;
        let ns = (bits as u128 * 1_000_000_000).div_ceil(bps);
        if ns > u64::MAX as u128 { u64::MAX } else { ns as u64 }
    }

    /// Whole bits that fit in `ns` nanoseconds.
    pub const fn ns_to_bits(self, ns: u64) -> u64 {
        (ns as u128 * self.0.get() as u128 / 1_000_000_000) as u64
    }
}

/// The length of one frame on the wire, in bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameBits {
    /// Bits from SOF to the end of the CRC sequence before stuffing.
    pub unstuffed: u32,
    /// Stuff bits inserted in that span.
    pub stuff: u32,
    /// The CRC-15 sequence of the frame.
    pub crc: u16,
}

impl FrameBits {
    /// Bits from SOF to the end of the CRC sequence after stuffing.
    pub const fn stuffed(&self) -> u32 {
        self.unstuffed + self.stuff
    }

    /// Bits from SOF to the end of EOF (when receivers accept the frame).
    pub const fn to_eof(&self) -> u32 {
        self.stuffed() + TRAILER_BITS
    }

    /// Bits the frame keeps the bus busy, intermission included.
    pub const fn total(&self) -> u32 {
        self.to_eof() + INTERMISSION_BITS
    }
}

/// At most 1+11+1+1+18+1+2+4+64 bits precede the CRC (extended, 8 bytes).
const MAX_BITS: usize = 103;

/// The bits SOF..end of data of a frame, dominant = `false`.
struct BitBuf {
    bits: [bool; MAX_BITS],
    len: usize,
}

impl BitBuf {
    fn push(&mut self, value: u32, width: u32) {
        for i in (0..width).rev() {
            if let Some(slot) = self.bits.get_mut(self.len) {
                *slot = (value >> i) & 1 == 1;
                self.len += 1;
            }
        }
    }

    fn as_slice(&self) -> &[bool] {
        self.bits.get(..self.len).unwrap_or(&self.bits)
    }
}

/// The CRC-15 of a bit sequence (generator 0x4599, initial value 0,
/// ISO 11898-1 §10.4.2.6).
pub fn crc15(bits: &[bool]) -> u16 {
    let mut crc: u16 = 0;
    for &bit in bits {
        let next = bit ^ (crc & 0x4000 != 0);
        crc = (crc << 1) & 0x7FFF;
        if next {
            crc ^= 0x4599;
        }
    }
    crc
}

/// Stuff bits needed for `bits` (run counting includes the stuff bits).
fn count_stuff_bits(bits: impl IntoIterator<Item = bool>) -> u32 {
    let mut stuff = 0;
    let mut last: Option<bool> = None;
    let mut run = 0u32;
    for bit in bits {
        if Some(bit) == last {
            run += 1;
        } else {
            last = Some(bit);
            run = 1;
        }
        if run == 5 {
            stuff += 1;
            // The stuff bit is the complement and starts a new run of one.
            last = Some(!bit);
            run = 1;
        }
    }
    stuff
}

/// The bits SOF..end of data of `frame` (dominant = `false`).
fn frame_header_and_data(frame: &CanFrame) -> BitBuf {
    let mut b = BitBuf { bits: [false; MAX_BITS], len: 0 };
    let rtr = u32::from(frame.is_remote_frame());
    let dlc = frame.dlc() as u32;
    b.push(0, 1); // SOF
    if frame.is_extended_id() {
        let id = frame.raw_id();
        b.push(id >> 18, 11);
        b.push(1, 1); // SRR
        b.push(1, 1); // IDE
        b.push(id & 0x3_FFFF, 18);
        b.push(rtr, 1);
        b.push(0, 2); // r1, r0
    } else {
        b.push(frame.raw_id(), 11);
        b.push(rtr, 1);
        b.push(0, 2); // IDE, r0
    }
    b.push(dlc, 4);
    for &byte in frame.data() {
        b.push(u32::from(byte), 8);
    }
    b
}

/// The exact length of `frame` on the wire.
pub fn frame_bits(frame: &CanFrame) -> FrameBits {
    let bits = frame_header_and_data(frame);
    let body = bits.as_slice();
    let crc = crc15(body);
    let crc_bits = (0..15).rev().map(|i| (crc >> i) & 1 == 1);
    let stuff = count_stuff_bits(body.iter().copied().chain(crc_bits));
    FrameBits { unstuffed: body.len() as u32 + 15, stuff, crc }
}

/// Nanoseconds `frame` keeps the bus busy at `rate`, intermission included.
pub fn frame_time_ns(frame: &CanFrame, rate: BitRate) -> u64 {
    rate.bits_to_ns(u64::from(frame_bits(frame).total()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn std(id: u16, data: &[u8]) -> CanFrame {
        CanFrame::standard(id, data).unwrap()
    }

    fn ext(id: u32, data: &[u8]) -> CanFrame {
        CanFrame::extended(id, data).unwrap()
    }

    /// `(unstuffed SOF..CRC, stuff bits, CRC, total bits with intermission)`.
    fn shape(f: &CanFrame) -> (u32, u32, u16, u32) {
        let b = frame_bits(f);
        (b.unstuffed, b.stuff, b.crc, b.total())
    }

    #[test]
    fn id_0_without_data_is_34_zeros_and_6_stuff_bits() {
        // SOF, 11 id bits, RTR, IDE, r0 and DLC 0000 are 19 dominant bits and
        // the CRC of all zeros is 0: 34 zeros. A stuff bit follows zeros
        // 5, 10, …, 30 (each stuff bit starts a new run): 6 stuff bits.
        // 40 stuffed + 10 trailer + 3 intermission = 53 bits = 53 µs at 1 Mbit/s.
        assert_eq!(shape(&std(0, &[])), (34, 6, 0, 53));
        assert_eq!(frame_time_ns(&std(0, &[]), BitRate::MBIT_1), 53_000);
        assert_eq!(frame_time_ns(&std(0, &[]), BitRate::KBIT_125), 424_000);
    }

    #[test]
    fn eight_zero_bytes_at_1_mbit() {
        // SOF..r0 are 15 zeros: stuff bits after zeros 5, 10 and 15 (3).
        // The third stuff bit (1) and the DLC's leading 1 make a run of two.
        // Then DLC 000, 64 zero data bits and the CRC 0x145B =
        // 001010001011011, which starts with two zeros: a run of
        // 3 + 64 + 2 = 69 zeros, stuffed after zeros 5, 10, …, 65 (13).
        // The CRC's rest has no run of five. 98 + 3 + 13 = 114 stuffed bits,
        // + 10 trailer + 3 intermission = 127 bits = 127 µs at 1 Mbit/s.
        assert_eq!(shape(&std(0, &[0; 8])), (98, 16, 0x145B, 127));
        assert_eq!(frame_time_ns(&std(0, &[0; 8]), BitRate::MBIT_1), 127_000);
    }

    #[test]
    fn frame_lengths_match_an_independent_reference() {
        // Reference values from a separate implementation that builds the
        // stuffed bit string (CRC by polynomial long division; that
        // implementation gives the catalogue check value 0x059E for "123456789").
        assert_eq!(shape(&std(0x7FF, &[])), (34, 3, 10031, 50));
        assert_eq!(shape(&std(0x601, &[0x40, 0, 0x10, 0, 0, 0, 0, 0])), (98, 13, 6426, 124));
        assert_eq!(shape(&std(0x123, &[0x11, 0x22, 0x33])), (58, 1, 26093, 72));
        assert_eq!(shape(&std(0x7FF, &[0xFF; 8])), (98, 15, 19593, 126));
        assert_eq!(shape(&std(0, &[0xAA; 8])), (98, 4, 5024, 115));
        assert_eq!(shape(&ext(0x1ABC_DEF0, &[1])), (62, 5, 20528, 80));
        assert_eq!(shape(&ext(0, &[])), (54, 7, 17936, 74));
        assert_eq!(shape(&CanFrame::remote(0x701, 1).unwrap()), (34, 4, 31200, 51));
        let ext_rtr = embedded_can::Frame::new_remote(embedded_can::ExtendedId::MAX, 8).unwrap();
        assert_eq!(shape(&ext_rtr), (54, 7, 6986, 74));
    }

    #[test]
    fn crc15_check_value() {
        // CRC-15/CAN catalogue check: the bits of ASCII "123456789" → 0x059E.
        let bits: Vec<bool> = b"123456789".iter().flat_map(|&c| (0..8).rev().map(move |i| (c >> i) & 1 == 1)).collect();
        assert_eq!(crc15(&bits), 0x059E);
        assert_eq!(crc15(&[]), 0);
    }

    #[test]
    fn stuff_counter_counts_stuff_bits_into_runs() {
        assert_eq!(count_stuff_bits([false; 4]), 0);
        assert_eq!(count_stuff_bits([false; 5]), 1, "a stuff bit follows a final run of five");
        assert_eq!(count_stuff_bits([false; 9]), 1);
        assert_eq!(count_stuff_bits([false; 10]), 2);
        // 00000 [1] 1111: the stuff bit plus four ones make a run of five.
        assert_eq!(count_stuff_bits([false, false, false, false, false, true, true, true, true]), 2);
    }

    #[test]
    fn bit_rates() {
        assert_eq!(BitRate::KBIT_800.bits_to_ns(1), 1_250);
        assert_eq!(BitRate::KBIT_125.bits_to_ns(53), 424_000);
        assert_eq!(BitRate::new(0), None);
        assert_eq!(BitRate::new(3).map(|r| r.bits_to_ns(1)), Some(333_333_334));
        assert_eq!(BitRate::KBIT_800.ns_to_bits(12_499), 9);
        assert_eq!(BitRate::from_cia_index(5), None);
        assert_eq!(BitRate::from_cia_index(8), Some(BitRate::KBIT_10));
        assert_eq!(BitRate::MBIT_1.bits_to_ns(u64::MAX), u64::MAX);
    }
}
