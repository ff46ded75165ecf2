//! The b maXX 4400 synchronised to the SYNC (§5.4 M-L2293-2365; P0830 bit 6
//! "Reset nach einem SYNC-Telegrammausfall" and bit 8, the PLL, §4.3.7/§4.3.8
//! M-L749-762; D66 in docs/devices/bmaxx4400.md): with a SYNC interval in
//! 0x1006 the drive's position control (ip, −4) follows the SYNC, and a SYNC
//! that does not come, or comes outside the tolerance, is drive error 00A5h
//! "Regler nicht synchron zu externem Signal", EMCY 8100h (§5.6.2). Exact
//! EMCY frames with their time; node 4.

mod common;

use canopen_core::time::Instant;
use common::{Bench, ms, ok_write};
use firmware::devices::bmaxx4400;
use hal_host::storage::MemStorage;

type Bmaxx = Bench<bmaxx4400::od::Ram, bmaxx4400::App, MemStorage, 4, 4, 0>;

const ID: u8 = 4;
const SYNC: u16 = 0x080;
const RPDO2: u16 = 0x304;
const EMCY: u16 = 0x084;
const P0830: u16 = 0x433E;
/// EMCY 8100h with drive error 00A5h (the error register as the core derives it for 81xxh).
const NOT_SYNCHRONOUS: [u8; 8] = [0x00, 0x81, 0x11, 0x00, 0xA5, 0, 0, 0];

/// P0830 = `word`, 0x1006 = `period` µs, Operational, Operation enabled in ip
/// (0x6060 = 7, RPDO2) at 100-300 ms.
fn enabled_ip(word: u16, period: u32) -> Bmaxx {
    let mut b = Bench::new(bmaxx4400::od::Ram::new(ID), bmaxx4400::App::NEW, MemStorage::new(8192), ID);
    b.at(ms(0));
    assert_eq!(b.sdo_write(ID, P0830, 0, &word.to_le_bytes()), ok_write(P0830, 0));
    assert_eq!(b.sdo_write(ID, 0x1006, 0, &period.to_le_bytes()), ok_write(0x1006, 0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    for (t, cw) in [(100, 0x06u8), (200, 0x07), (300, 0x0F)] {
        b.rx(ms(t), RPDO2, &[cw, 0, 7]);
    }
    b
}

/// SYNCs every `step` µs from `from` µs up to `to` µs; the EMCYs with their time [µs].
fn syncs(b: &mut Bmaxx, from: u64, to: u64, step: u64) -> Vec<(u64, Vec<u8>)> {
    let mut emcy = Vec::new();
    for t in (from..=to).step_by(step as usize) {
        emcy.extend(
            b.run_until(Instant::from_micros(t)).into_iter().filter(|(_, (id, _))| *id == EMCY).map(|(at, (_, d))| (at.as_micros(), d)),
        );
        emcy.extend(b.rx(Instant::from_micros(t), SYNC, &[]).into_iter().filter(|(id, _)| *id == EMCY).map(|(_, d)| (t, d)));
    }
    emcy
}

/// The EMCYs with their time [µs] up to `to` ms.
fn emcys_until(b: &mut Bmaxx, to: u64) -> Vec<(u64, Vec<u8>)> {
    b.run_until(ms(to)).into_iter().filter(|(_, (id, _))| *id == EMCY).map(|(at, (_, d))| (at.as_micros(), d)).collect()
}

fn statusword(b: &mut Bmaxx) -> u16 {
    let v = b.sdo_upload(ID, 0x6041, 0).expect("0x6041");
    u16::from_le_bytes([v[0], v[1]])
}

#[test]
fn m_l2349_a_sync_loss_is_drive_error_00a5h_acknowledged_once_the_pll_runs_in_step_again() {
    // 0x1006 = 2000 µs, SYNCs every 2 ms from 400 to 500 ms, then none: with the PLL (bit 8 = 0)
    // a SYNC may be up to 1 ms late; still none at the 504 ms tick is the loss, and the
    // profile's next tick (505 ms) takes the drive's fault.
    let mut b = enabled_ip(0, 2000);
    assert_eq!(syncs(&mut b, 400_000, 500_000, 2000), []);
    assert_eq!(emcys_until(&mut b, 600), [(505_000, NOT_SYNCHRONOUS.to_vec())]);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "Fault");
    // The SYNC back at 1 s: without bit 6 the PLL may take "im worst case eine halbe Minute"
    // to run in step again; a fault reset before that acknowledges nothing.
    assert_eq!(syncs(&mut b, 1_000_000, 2_000_000, 2000), []);
    assert_eq!(b.rx(ms(2001), RPDO2, &[0x80, 0, 7]).into_iter().filter(|(id, _)| *id == EMCY).count(), 0);
    assert_eq!(statusword(&mut b) & 0x4F, 0x08, "still Fault");
    // After 30 s of SYNCs without a gap: "Error Reset / No Error" (B17), Switch on disabled.
    b.rx(ms(2002), RPDO2, &[0x00, 0, 7]);
    assert_eq!(syncs(&mut b, 2_002_000, 31_000_000, 2000), []);
    assert_eq!(b.rx(ms(31_001), RPDO2, &[0x80, 0, 7]).into_iter().filter(|(id, _)| *id == EMCY).collect::<Vec<_>>(), [(EMCY, vec![0; 8])]);
    assert_eq!(statusword(&mut b), 0x0250, "Switch on disabled");
}

#[test]
fn m_l751_p0830_bit_6_resets_the_synchronisation_after_a_sync_loss() {
    // Bit 6 = 1: "Reset der Synchronisation nach einem SYNC-Telegrammausfall": in step with
    // the first SYNC back, so the fault reset acknowledges the error at once.
    let mut b = enabled_ip(0x0040, 2000);
    syncs(&mut b, 400_000, 500_000, 2000);
    assert_eq!(emcys_until(&mut b, 600), [(505_000, NOT_SYNCHRONOUS.to_vec())]);
    assert_eq!(syncs(&mut b, 1_000_000, 1_010_000, 2000), []);
    assert_eq!(b.rx(ms(1011), RPDO2, &[0x80, 0, 7]).into_iter().filter(|(id, _)| *id == EMCY).collect::<Vec<_>>(), [(EMCY, vec![0; 8])]);
    assert_eq!(statusword(&mut b), 0x0250, "Switch on disabled");
    // Enabled again in −4 (position control, the same interpolation): the SYNCs keep it running.
    let mut emcy = Vec::new();
    for (t, cw) in [(1012, 0x06u8), (1014, 0x07), (1016, 0x0F)] {
        emcy.extend(syncs(&mut b, t * 1000, t * 1000, 2000));
        b.rx(ms(t), RPDO2, &[cw, 0, 0xFC]);
    }
    emcy.extend(syncs(&mut b, 1_018_000, 1_100_000, 2000));
    assert_eq!(emcy, []);
    assert_eq!(statusword(&mut b) & 0x6F, 0x27, "Operation enabled");
}

#[test]
fn m_l757_p0830_bit_8_without_the_pll_a_sync_off_by_more_than_40_us_is_the_error() {
    // The PLL "dient zum Ausgleich von größerem Jitter des Sync-Telegramms": with it (bit 8 = 0)
    // a SYNC 100 µs late is in step; without it (bit 8 = 1) the drive's "Sync Toleranz:
    // max. 40 µs" applies, and the late SYNC is the error (the fault on the next tick). Without
    // 0x1006 nothing is monitored: "Wird der Regler nicht über CANopen synchronisiert, darf im
    // Regler keine Überwachung der Synchronisierung erfolgen".
    for (word, period, expected) in
        [(0x0000u16, 2000, vec![]), (0x0100, 2000, vec![(405_000, NOT_SYNCHRONOUS.to_vec())]), (0x0100, 0, vec![])]
    {
        let mut b = enabled_ip(word, period);
        let mut emcy = syncs(&mut b, 400_000, 402_000, 2000);
        emcy.extend(syncs(&mut b, 404_100, 404_100, 2000));
        emcy.extend(syncs(&mut b, 406_100, 420_100, 2000));
        assert_eq!(emcy, expected, "P0830 = {word:04X}h, 0x1006 = {period} µs");
    }
}
