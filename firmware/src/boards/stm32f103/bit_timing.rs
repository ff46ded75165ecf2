//! bxCAN bit timing (the BTR register) for a bit rate, computed from the
//! CAN clock (APB1) so the bit rate is configuration, not a magic number.
//!
//! A bit is `1 + TS1 + TS2` time quanta of `BRP / f_APB1` each (RM0008
//! §24.7.7). The search takes the timing whose sample point,
//! `(1 + TS1) / (1 + TS1 + TS2)`, is closest to 87.5 %, the value CiA
//! recommends for every CANopen bit rate, and prefers more quanta on a tie.

/// The sample point aimed at, in per mille.
const SAMPLE_POINT_PERMILLE: u32 = 875;

/// The BTR value for `bit_rate` bit/s from a CAN clock of `pclk_hz`, with a
/// resynchronisation jump width of one quantum; `None` if no prescaler
/// divides the clock exactly.
pub const fn btr(pclk_hz: u32, bit_rate: u32) -> Option<u32> {
    if bit_rate == 0 {
        return None;
    }
    let mut best: Option<(u32, u32, u32, u32)> = None; // (error, brp, ts1, ts2)
    // bxCAN allows TS1 1..=16 and TS2 1..=8, so 3..=25 quanta; below 8 the
    // sample point cannot get near 87.5 %.
    let mut quanta = 25;
    while quanta >= 8 {
        let per_bit = bit_rate * quanta;
        if pclk_hz.is_multiple_of(per_bit) {
            let brp = pclk_hz / per_bit;
            // TS2 = the quanta after the sample point, rounded.
            let ts2 = (quanta * (1000 - SAMPLE_POINT_PERMILLE) + 500) / 1000;
            let ts1 = quanta - 1 - ts2;
            if brp >= 1 && brp <= 1024 && ts2 >= 1 && ts2 <= 8 && ts1 >= 1 && ts1 <= 16 {
                let sample = (1 + ts1) * 1000 / quanta;
                let error = sample.abs_diff(SAMPLE_POINT_PERMILLE);
                let better = match best {
                    Some((e, ..)) => error < e,
                    None => true,
                };
                if better {
                    best = Some((error, brp, ts1, ts2));
                }
            }
        }
        quanta -= 1;
    }
    match best {
        Some((_, brp, ts1, ts2)) => Some(((ts2 - 1) << 20) | ((ts1 - 1) << 16) | (brp - 1)),
        None => None,
    }
}

/// The bit rate in kbit/s of CiA 305 bit-timing table index `index`
/// (bit `index` of the EDS's supported bit rates).
pub const fn cia305_kbps(index: u8) -> Option<u32> {
    Some(match index {
        0 => 1000,
        1 => 800,
        2 => 500,
        3 => 250,
        4 => 125,
        6 => 50,
        7 => 20,
        8 => 10,
        _ => return None,
    })
}

/// The BTR value for each CiA 305 table index (0 = 1 Mbit/s … 8 = 10
/// kbit/s) from a CAN clock of `pclk_hz`; `None` for the reserved index 5
/// and rates the clock cannot make. Meant for a `const`, so the search runs
/// at compile time and the image only holds the table.
pub const fn table(pclk_hz: u32) -> [Option<u32>; 9] {
    let mut table = [None; 9];
    let mut index = 0;
    while index < table.len() {
        if let Some(kbps) = cia305_kbps(index as u8) {
            table[index] = btr(pclk_hz, kbps * 1000);
        }
        index += 1;
    }
    table
}

/// The CiA 305 table index of `kbps`, if it is one of the table's rates.
pub fn cia305_index(kbps: u32) -> Option<u8> {
    (0..=8).find(|&index| cia305_kbps(index) == Some(kbps))
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    fn decode(btr: u32) -> (u32, u32, u32) {
        ((btr & 0x3FF) + 1, ((btr >> 16) & 0xF) + 1, ((btr >> 20) & 0x7) + 1)
    }

    #[test]
    fn every_cia305_rate_from_36_mhz() {
        for index in 0..=8 {
            let Some(kbps) = cia305_kbps(index) else { continue };
            let btr = btr(36_000_000, kbps * 1000).unwrap_or_else(|| panic!("{kbps} kbit/s"));
            let (brp, ts1, ts2) = decode(btr);
            let quanta = 1 + ts1 + ts2;
            assert_eq!(36_000_000 / (brp * quanta), kbps * 1000, "{kbps} kbit/s");
            let sample = (1 + ts1) * 1000 / quanta;
            assert!((850..=900).contains(&sample), "{kbps} kbit/s: sample point {sample}");
            assert_eq!(btr >> 24, 0, "SJW 1, normal mode");
        }
    }

    #[test]
    fn the_table_holds_every_cia305_rate() {
        let table = table(36_000_000);
        for index in 0..=8u8 {
            let expected = cia305_kbps(index).and_then(|kbps| btr(36_000_000, kbps * 1000));
            assert_eq!(table[usize::from(index)], expected, "index {index}");
            assert_eq!(cia305_index(cia305_kbps(index).unwrap_or(0)), cia305_kbps(index).map(|_| index));
        }
        assert_eq!(table[3], Some(0x001C_0008), "250 kbit/s");
        assert_eq!(table[5], None, "reserved");
        assert_eq!(cia305_index(100), None);
    }

    #[test]
    fn known_values() {
        // 250 kbit/s from 36 MHz: 9 × 16 quanta, TS1 13, TS2 2 (87.5 %).
        assert_eq!(btr(36_000_000, 250_000), Some(0x001C_0008));
        // 125 kbit/s from 8 MHz (the stm32f1xx-hal example's 0x001c_0003).
        assert_eq!(btr(8_000_000, 125_000), Some(0x001C_0003));
        assert_eq!(btr(36_000_000, 0), None);
        assert_eq!(btr(36_000_000, 33_333), None);
    }
}
