//! The device slot: each hook of `Application`, with its context, driven
//! with exact frames on the virtual clock. A probe application logs what it
//! hears and does what each test needs; each test fails without its hook.

mod common;

use canopen_core::abort::AbortCode;
use canopen_core::node::{Application, Claims, CommError, ControllerEvent, Ctx, NmtEvent, NoApplication, Source};
use canopen_core::od::Dictionary;
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;
use canopen_core::wire::time_stamp::TimeOfDay;
use common::{Bench, abort, ms, ok_write};
use hal_host::fixtures::interop::od::Ram;
use hal_host::storage::MemStorage;

const ID: u8 = 5;
const SDO_RX: u16 = 0x605;
const TPDO1: u16 = 0x185;
const RPDO1: u16 = 0x205;
/// A raw identifier the probe claims.
const RAW_IN: u16 = 0x3A0;
const RAW_OUT: u16 = 0x3A1;

/// Logs every hook call and acts as the tests need.
#[derive(Default)]
struct Probe {
    log: Vec<String>,
    /// Send this many raw frames at each poll.
    raw_per_poll: usize,
    /// Poll period, if the probe runs a timer.
    period_ms: Option<u64>,
    sync_count: u32,
    /// What storing the read-only 0x1001 alone gave (beside 0x2004's store).
    saved_read_only: Option<Result<(), AbortCode>>,
}

impl Application for Probe {
    fn upload_size(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        (index == 0x2FFF).then_some(if sub == 0 { Ok(4) } else { Err(AbortCode::NoSubIndex) })
    }

    fn read(&mut self, ctx: &mut Ctx<'_>, index: u16, _sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
        // 0x2FFF: the time in ms, computed on read.
        let value = ((ctx.now().as_micros() / 1000) as u32).to_le_bytes();
        (index == 0x2FFF).then(|| {
            let src = value.get(offset..).unwrap_or(&[]);
            let n = src.len().min(buf.len());
            buf[..n].copy_from_slice(&src[..n]);
            Ok(n)
        })
    }

    fn download_check(&mut self, _ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        // A 1-byte heartbeat time, and one write to 0x2100 sub 0 for all four entries.
        match (index, sub, size) {
            (0x1017, 0, Some(1)) | (0x2100, 0, Some(2)) => Some(Ok(())),
            _ => None,
        }
    }

    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        match (index, sub, data) {
            (0x1017, 0, [ms]) => Some(ctx.write_object(0x1017, 0, &[*ms, 0])),
            (0x2100, 0, [lo, hi]) => Some((1..=4).try_for_each(|s| ctx.write_object(0x2100, s, &[*lo, *hi]))),
            _ => None,
        }
    }

    fn check_write(&mut self, ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.log.push(format!("check {index:04X}:{sub} {data:02X?}"));
        match (index, data) {
            // A communication object: heartbeat times of 7 ms are refused with a device code.
            (0x1017, [7, 0]) => Err(AbortCode::DeviceState),
            // An object checked against another: 0x2000 at most 0x2001's low byte.
            (0x2000, [v]) if u32::from(*v) > ctx.read_u32(0x2001, 0).unwrap_or(0) & 0xFF => Err(AbortCode::ValueTooHigh),
            _ => Ok(()),
        }
    }

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, by: Source) {
        self.log.push(format!("written {index:04X}:{sub} {by:?}"));
        match (index, sub, by) {
            // An RPDO's first object drives a status byte in TPDO1 (0x2000), as 0x6040 drives 0x6041.
            (0x2100, 1, Source::Rpdo(0)) => {
                let v = ctx.read(0x2100, 1).map(|b| b[0]).unwrap_or(0);
                ctx.set_value(0x2000, 0, &[v ^ 0xFF]).unwrap();
            }
            // 0x2100:2 = 0xEEEE from an RPDO is a serious device error of class 1 (0x1029:1).
            (0x2100, 2, Source::Rpdo(0)) if ctx.read_u32(0x2100, 2) == Some(0xEEEE) => ctx.error_behaviour(1),
            // 0x2004 is stored alone as soon as it is written.
            (0x2004, 0, _) => {
                ctx.save_objects(0x2004, 0x2004).unwrap();
                self.saved_read_only = Some(ctx.save_objects(0x1001, 0x1001));
            }
            // 0x2001 = 0xDEAD is a device error (EMCY 0xFF01), any other value clears it.
            (0x2001, 0, _) => {
                if ctx.read_u32(0x2001, 0) == Some(0xDEAD) {
                    ctx.raise_error(EmcyCode(0xFF01), [1, 2, 3, 4, 5]);
                } else {
                    ctx.clear_error(EmcyCode(0xFF01));
                }
            }
            // 0x2003 names a raw identifier the probe claims; a write of 0x2002 (not in TPDO1) is an application event for TPDO1.
            (0x2003, 0, Source::Sdo) => ctx.refresh_acceptance(),
            (0x2002, 0, Source::Sdo) => {
                ctx.trigger_tpdo(0);
            }
            _ => {}
        }
    }

    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        self.sync_count += 1;
        self.log.push("sample".into());
        ctx.set_value(0x2003, 0, &self.sync_count.to_le_bytes()).unwrap();
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let period = self.period_ms?;
        for i in 0..self.raw_per_poll {
            ctx.send_raw(RAW_OUT, &[i as u8]);
        }
        let now = ctx.now().as_micros() / 1000;
        Some(ms(now - now % period + period))
    }

    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        self.log.push(format!("nmt {event:?} in {:?}", ctx.state()));
    }

    fn on_time(&mut self, _ctx: &mut Ctx<'_>, time: TimeOfDay) {
        self.log.push(format!("time {time:?}"));
    }

    fn on_frame(&mut self, ctx: &mut Ctx<'_>, cob_id: u16, rtr: bool, data: &[u8]) -> bool {
        if cob_id != RAW_IN || rtr {
            return false;
        }
        self.log.push(format!("raw {data:02X?} in {:?}", ctx.state()));
        ctx.send_raw(RAW_OUT, data)
    }

    fn claim_ids(&self, dict: &'static Dictionary, image: &[u8], claims: &mut Claims<'_>) {
        claims.claim(RAW_IN, false);
        if let Some(id @ 1..=0x7FF) = dict.read_u32(image, 0x2003, 0) {
            claims.claim(id as u16, false);
        }
    }
}

type B<A> = Bench<Ram, A, MemStorage, 4, 4, 4>;

fn bench(app: Probe) -> B<Probe> {
    let mut b = Bench::new(Ram::new(ID), app, MemStorage::new(4096), ID);
    assert!(b.at(ms(0)).contains(&(0x705, vec![0x00])), "boot-up");
    b
}

fn log(b: &mut B<Probe>) -> Vec<String> {
    std::mem::take(&mut b.node.app_mut().log)
}

#[test]
fn an_rpdo_object_reacts_and_the_change_of_state_tpdo_leaves_in_the_same_process() {
    let mut b = bench(Probe::default());
    b.nmt(0x01, ID);
    log(&mut b);
    // RPDO1 maps 0x2100 sub 1..4; the hook turns sub 1 into 0x2000, which TPDO1 (type 255) carries.
    let out = b.rx(ms(10), RPDO1, &[0x0F, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(out, [(TPDO1, vec![0xF0, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44])]);
    assert_eq!(log(&mut b), ["written 2100:1 Rpdo(0)", "written 2100:2 Rpdo(0)", "written 2100:3 Rpdo(0)", "written 2100:4 Rpdo(0)"]);
}

#[test]
fn an_rpdo_hook_that_reports_a_device_error_changes_the_state_as_0x1029_says() {
    // The RPDO's hook has a follow-up of its own (`Node::with_app_follow`):
    // the error class it reports is acted on there too.
    let mut b = bench(Probe::default());
    b.nmt(0x01, ID);
    b.rx(ms(10), RPDO1, &[0x0F, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(b.node.state(), NmtState::Operational);
    // 0x1029:1 = 1: no change.
    assert_eq!(b.sdo_write(ID, 0x1029, 1, &[1]), ok_write(0x1029, 1));
    b.rx(ms(20), RPDO1, &[0x0F, 0x00, 0xEE, 0xEE, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(b.node.state(), NmtState::Operational, "0x1029:1 = 1");
    // 0x1029:1 = 0: Pre-operational.
    assert_eq!(b.sdo_write(ID, 0x1029, 1, &[0]), ok_write(0x1029, 1));
    b.rx(ms(30), RPDO1, &[0x0F, 0x00, 0xEE, 0xEE, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(b.node.state(), NmtState::PreOperational, "0x1029:1 = 0");
    log(&mut b);
}

#[test]
fn validation_sees_every_object_after_the_dictionary_checks_and_refuses_with_any_code() {
    let mut b = bench(Probe::default());
    log(&mut b);
    // Too long for 0x1017: the dictionary answers, the hook never sees it.
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &[7, 0, 0, 0]), Err(0x0607_0012));
    assert_eq!(log(&mut b), Vec::<String>::new());
    // A communication object refused with a device code: heartbeat stays off.
    assert_eq!(b.sdo_write(ID, 0x1017, 0, &[7, 0]), abort(0x1017, 0, 0x0800_0022));
    assert_eq!(b.run_until(ms(100)), []);
    // Checked against another object: 0x2001 = 0x2222, so 0x2000 may be at most 0x22.
    assert_eq!(b.sdo_write(ID, 0x2000, 0, &[0x23]), abort(0x2000, 0, 0x0609_0031));
    assert_eq!(b.sdo_upload(ID, 0x2000, 0), Ok(vec![0x11]));
    assert_eq!(b.sdo_write(ID, 0x2000, 0, &[0x22]), ok_write(0x2000, 0));
    assert_eq!(log(&mut b), ["check 1017:0 [07, 00]", "check 2000:0 [23]", "check 2000:0 [22]", "written 2000:0 Sdo"]);
}

#[test]
fn served_objects_have_their_own_length_rules_fan_out_and_compute_reads() {
    let mut b = bench(Probe::default());
    // 2F 17 10 00 64: a 1-byte heartbeat time, written through the services (the producer starts).
    assert_eq!(b.rx(ms(0), SDO_RX, &[0x2F, 0x17, 0x10, 0x00, 0x64, 0, 0, 0]), [(0x585, ok_write(0x1017, 0))]);
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(vec![0x64, 0x00]));
    assert_eq!(b.run_until(ms(200)), [(ms(100), (0x705, vec![0x7F])), (ms(200), (0x705, vec![0x7F]))]);
    // One write to sub 0 sets the four entries.
    assert_eq!(b.sdo_write(ID, 0x2100, 0, &[0x34, 0x12]), ok_write(0x2100, 0));
    for sub in 1..=4 {
        assert_eq!(b.sdo_upload(ID, 0x2100, sub), Ok(vec![0x34, 0x12]));
    }
    // A value computed on read: the time in ms.
    b.at(ms(1234));
    assert_eq!(b.sdo_upload(ID, 0x2FFF, 0), Ok(1234u32.to_le_bytes().to_vec()));
}

#[test]
fn an_application_write_goes_through_the_services_and_is_heard() {
    let mut b = bench(Probe::default());
    b.nmt(0x01, ID);
    log(&mut b);
    assert_eq!(b.node.write_object(ms(5), 0x2000, 0, &[0x21]), Ok(()));
    assert_eq!(b.node.write_object(ms(5), 0x1017, 0, &[7, 0]), Err(AbortCode::DeviceState), "validated as an SDO write");
    assert_eq!(b.at(ms(5)), [(TPDO1, vec![0x21, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44])]);
    assert_eq!(log(&mut b), ["check 2000:0 [21]", "written 2000:0 App", "check 1017:0 [07, 00]"]);
}

#[test]
fn the_device_samples_before_the_synchronous_tpdos_are_built() {
    let mut b = bench(Probe::default());
    // TPDO1 synchronous, every SYNC.
    assert_eq!(b.sdo_write(ID, 0x1800, 2, &[1]), ok_write(0x1800, 2));
    b.nmt(0x01, ID);
    let tpdo1 = |out: Vec<common::F>| out.into_iter().filter(|f| f.0 == TPDO1).collect::<Vec<_>>();
    let out = tpdo1(b.rx(ms(10), 0x080, &[]));
    assert_eq!(out, [(TPDO1, vec![0x11, 0x22, 0x22, 0x01, 0x00, 0x00, 0x00])], "the value sampled for this SYNC");
    let out = tpdo1(b.rx(ms(20), 0x080, &[]));
    assert_eq!(out, [(TPDO1, vec![0x11, 0x22, 0x22, 0x02, 0x00, 0x00, 0x00])]);
}

#[test]
fn device_timers_run_in_process_on_the_virtual_clock() {
    let mut b = bench(Probe { period_ms: Some(10), raw_per_poll: 1, ..Probe::default() });
    let out = b.run_until(ms(35));
    let times: Vec<u64> = out.iter().filter(|(_, f)| f.0 == RAW_OUT).map(|(t, _)| t.as_micros() / 1000).collect();
    assert_eq!(times, [0, 10, 20, 30, 35], "at each call: the first at 0, the deadlines the device returned, the final call");
}

#[test]
fn raw_frames_keep_a_reserve_of_the_queue_and_an_overflow_is_signalled() {
    let mut b = bench(Probe { period_ms: Some(1), raw_per_poll: 4, ..Probe::default() });
    // Run without sending: the raw frames fill the queue up to the reserve, no further.
    for t in 1..=10 {
        b.node.process(ms(t));
    }
    assert_eq!(b.node.tx_overflows(), 4 * 10 - (32 - 8) as u32);
    let out = b.at(ms(11));
    // This process's four frames found the queue at its reserve too.
    assert_eq!(b.node.tx_overflows(), 4 * 11 - (32 - 8) as u32);
    assert_eq!(out.iter().filter(|f| f.0 == RAW_OUT).count(), 24);
    // One EMCY 0x8110 for the whole overflow (bytes 3–6: 4 frames refused
    // when it was raised, byte 7 = 1: the transmit queue), not one per call.
    let emcys: Vec<&(u16, Vec<u8>)> = out.iter().filter(|f| f.0 == 0x85).collect();
    assert_eq!(emcys, [&(0x85, vec![0x10, 0x81, 0x11, 4, 0, 0, 0, 1])], "EMCY 0x8110 CAN overrun: {out:x?}");
}

#[test]
fn nmt_and_communication_events_arrive_each_one_whatever_0x1029_says() {
    let mut b = bench(Probe::default());
    assert_eq!(
        log(&mut b),
        ["nmt ResetApplication in Initialising", "nmt ResetCommunication in Initialising", "nmt Entered(PreOperational) in PreOperational"]
    );
    // Operational → Stopped → Operational: three events.
    b.nmt(0x01, ID);
    b.nmt(0x02, ID);
    b.nmt(0x01, ID);
    assert_eq!(
        log(&mut b),
        ["nmt Entered(Operational) in Operational", "nmt Entered(Stopped) in Stopped", "nmt Entered(Operational) in Operational"]
    );
    // 0x1029:1 = 1 (no state change); consume node 9's heartbeat at 100 ms.
    assert_eq!(b.sdo_write(ID, 0x1029, 1, &[1]), ok_write(0x1029, 1));
    assert_eq!(b.sdo_write(ID, 0x1016, 1, &[0x64, 0x00, 0x09, 0x00]), ok_write(0x1016, 1));
    b.rx(ms(10), 0x709, &[0x05]);
    b.run_until(ms(200));
    // RPDO1 with an event timer of 50 ms that times out.
    assert_eq!(b.sdo_write(ID, 0x1400, 5, &[50, 0]), ok_write(0x1400, 5));
    b.rx(ms(210), RPDO1, &[1, 0, 2, 0, 3, 0, 4, 0]);
    b.run_until(ms(300));
    // Two frames of RPDO1 shorter than its 8 mapped bytes, one of the right length between: each short one.
    b.rx(ms(300), RPDO1, &[1, 0]);
    b.rx(ms(300), RPDO1, &[1, 0, 2, 0, 3, 0, 4, 0]);
    b.rx(ms(300), RPDO1, &[1, 0, 2, 0, 3, 0, 4]);
    // The board reports the recovery from a bus-off (bxCAN's TX-empty interrupt with BOFF clear).
    b.node.controller_event(ControllerEvent::BusOffRecovered, ms(300));
    b.at(ms(300));
    let events: Vec<String> = log(&mut b).into_iter().filter(|l| l.starts_with("nmt")).collect();
    assert_eq!(
        events,
        [
            "nmt CommunicationError(Heartbeat(9)) in Operational",
            "nmt CommunicationError(RpdoTimeout(0)) in Operational",
            "nmt CommunicationError(RpdoLength(0)) in Operational",
            "nmt CommunicationError(RpdoLength(0)) in Operational",
            "nmt CommunicationError(BusOff) in Operational"
        ]
    );
    assert_eq!(b.node.state(), NmtState::Operational, "0x1029:1 = 1: no state change");
    // Reset node: reset application, reset communication, then Pre-operational after the boot-up.
    b.nmt(0x81, ID);
    assert_eq!(
        log(&mut b),
        ["nmt ResetApplication in Initialising", "nmt ResetCommunication in Initialising", "nmt Entered(PreOperational) in PreOperational"]
    );
}

#[test]
fn raw_frames_are_claimed_and_seen_in_every_nmt_state() {
    let mut b = bench(Probe::default());
    assert!(b.node.acceptance().accepts(RAW_IN, false), "the board's filter passes the claimed identifier");
    assert!(!b.node.acceptance().accepts(RAW_OUT, false));
    b.nmt(0x02, ID);
    log(&mut b);
    assert_eq!(b.rx(ms(1), RAW_IN, &[0xAB]), [(RAW_OUT, vec![0xAB])]);
    assert_eq!(log(&mut b), ["raw [AB] in Stopped"]);
    // Without the claim the same frame is ignored.
    let mut plain: B<NoApplication> = Bench::new(Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    assert!(!plain.node.acceptance().accepts(RAW_IN, false));
    plain.at(ms(0));
    assert_eq!(plain.rx(ms(1), RAW_IN, &[0xAB]), []);
}

/// A device that speaks only its own protocol: no CANopen at all.
struct Foreign;

impl Application for Foreign {
    fn on_frame(&mut self, ctx: &mut Ctx<'_>, cob_id: u16, _rtr: bool, data: &[u8]) -> bool {
        cob_id == RAW_IN && ctx.send_raw(RAW_OUT, data)
    }

    fn claim_ids(&self, _dict: &'static Dictionary, _image: &[u8], claims: &mut Claims<'_>) {
        claims.claim(RAW_IN, false);
    }

    fn canopen(&self) -> bool {
        false
    }
}

#[test]
fn a_device_may_switch_the_canopen_services_off() {
    let mut b: B<Foreign> = Bench::new(Ram::new(ID), Foreign, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [], "no boot-up");
    assert_eq!(b.node.acceptance().ids().iter().map(|a| a.cob_id).collect::<Vec<_>>(), [RAW_IN]);
    assert_eq!(b.rx(ms(1), SDO_RX, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]), [], "no SDO");
    assert_eq!(b.rx(ms(2), 0x000, &[0x01, 0x00]), [], "no NMT");
    assert_eq!(b.rx(ms(3), RAW_IN, &[1, 2]), [(RAW_OUT, vec![1, 2])]);
    assert_eq!(b.run_until(ms(5000)), []);
}

/// Answers a frame on `RAW_IN` with a raw frame and keeps what `send_raw`
/// said; `F` is its `Application::RAW_FRAMES`.
#[derive(Default)]
struct RawFrames<const F: bool>(Vec<bool>);

impl<const F: bool> Application for RawFrames<F> {
    const RAW_FRAMES: bool = F;

    fn on_frame(&mut self, ctx: &mut Ctx<'_>, cob_id: u16, _rtr: bool, data: &[u8]) -> bool {
        if cob_id != RAW_IN {
            return false;
        }
        self.0.push(ctx.send_raw(RAW_OUT, data));
        true
    }

    fn claim_ids(&self, _dict: &'static Dictionary, _image: &[u8], claims: &mut Claims<'_>) {
        claims.claim(RAW_IN, false);
    }
}

/// What two frames on `RAW_IN` send, and what `send_raw` answered.
fn raw_frames<const F: bool>() -> (Vec<(u16, Vec<u8>)>, Vec<bool>) {
    let mut b: B<RawFrames<F>> = Bench::new(Ram::new(ID), RawFrames::default(), MemStorage::new(4096), ID);
    b.at(ms(0));
    let mut out = b.rx(ms(1), RAW_IN, &[1]);
    out.extend(b.rx(ms(2), RAW_IN, &[2]));
    (out, std::mem::take(&mut b.node.app_mut().0))
}

#[test]
fn a_device_without_raw_frames_has_send_raw_refuse() {
    assert_eq!(raw_frames::<true>(), (vec![(RAW_OUT, vec![1]), (RAW_OUT, vec![2])], vec![true, true]));
    // `RAW_FRAMES = false` (as `NoApplication`): nothing queues them, and the device hears so.
    assert_eq!(raw_frames::<false>(), (vec![], vec![false, false]), "no raw frame");
}

#[test]
fn a_device_stores_one_object_alone() {
    let mut b = bench(Probe::default());
    // An unsaved change elsewhere, then 0x2004, which the probe stores as soon as it is written.
    assert_eq!(b.sdo_write(ID, 0x2003, 0, &[1, 2, 3, 4]), ok_write(0x2003, 0));
    assert_eq!(b.sdo_write(ID, 0x2004, 0, &[0x07, 0, 0, 0]), ok_write(0x2004, 0));
    b.nmt(0x81, ID);
    assert_eq!(b.sdo_upload(ID, 0x2004, 0), Ok(vec![0x07, 0, 0, 0]), "stored");
    assert_eq!(b.sdo_upload(ID, 0x2003, 0), Ok(vec![0x44, 0x44, 0x44, 0x44]), "not stored");
    // A value no stored set holds (read-only, not kept by the build) is refused, not stored as nothing.
    assert_eq!(b.node.app().saved_read_only, Some(Err(AbortCode::CannotStore)));
    // A later 0x1010 save of everything keeps 0x2004 and adds 0x2003.
    assert_eq!(b.sdo_write(ID, 0x2003, 0, &[1, 2, 3, 4]), ok_write(0x2003, 0));
    assert_eq!(b.sdo_write(ID, 0x1010, 1, b"save"), ok_write(0x1010, 1));
    assert_eq!(b.sdo_write(ID, 0x2004, 0, &[0x09, 0, 0, 0]), ok_write(0x2004, 0));
    b.nmt(0x81, ID);
    assert_eq!(b.sdo_upload(ID, 0x2003, 0), Ok(vec![1, 2, 3, 4]));
    assert_eq!(b.sdo_upload(ID, 0x2004, 0), Ok(vec![0x09, 0, 0, 0]));
}

#[test]
fn a_time_frame_reaches_the_device() {
    let mut b = bench(Probe::default());
    // Consume TIME on 0x100.
    assert_eq!(b.sdo_write(ID, 0x1012, 0, &[0x00, 0x01, 0x00, 0x80]), ok_write(0x1012, 0));
    log(&mut b);
    b.rx(ms(1), 0x100, &[0x10, 0x27, 0x00, 0x00, 0x01, 0x00]);
    assert_eq!(log(&mut b).len(), 1);
}

#[test]
fn a_device_raises_and_clears_errors_through_its_context() {
    let mut b = bench(Probe::default());
    let out = b.rx(ms(1), SDO_RX, &[0x2B, 0x01, 0x20, 0x00, 0xAD, 0xDE, 0, 0]);
    assert_eq!(out, [(0x85, vec![0x01, 0xFF, 0x81, 1, 2, 3, 4, 5]), (0x585, ok_write(0x2001, 0))], "EMCY 0xFF01, error register bit 7");
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(vec![0x01, 0xFF, 0x01, 0x02]));
    let out = b.rx(ms(2), SDO_RX, &[0x2B, 0x01, 0x20, 0x00, 0x00, 0x00, 0, 0]);
    assert_eq!(out, [(0x85, vec![0, 0, 0, 0, 0, 0, 0, 0]), (0x585, ok_write(0x2001, 0))], "error reset");
}

#[test]
fn a_device_triggers_a_tpdo_and_changes_its_claimed_identifiers() {
    let mut b = bench(Probe::default());
    // TPDO1 type 254: with the same data only an application event sends it.
    assert_eq!(b.sdo_write(ID, 0x1800, 2, &[0xFE]), ok_write(0x1800, 2));
    b.nmt(0x01, ID);
    b.at(ms(1));
    assert_eq!(b.sdo_write(ID, 0x2000, 0, &[0x11]), ok_write(0x2000, 0));
    assert_eq!(b.at(ms(2)), [], "the same data: no change of state");
    assert!(!b.node.acceptance().accepts(0x3B0, false));
    let generation = b.node.acceptance().generation();
    let out = b.rx(ms(3), SDO_RX, &[0x23, 0x03, 0x20, 0x00, 0xB0, 0x03, 0, 0]);
    assert_eq!(out, [(TPDO1, vec![0x11, 0x22, 0x22, 0xB0, 0x03, 0x00, 0x00]), (0x585, ok_write(0x2003, 0))]);
    assert!(b.node.acceptance().accepts(0x3B0, false), "claimed after the refresh");
    assert_ne!(b.node.acceptance().generation(), generation);
    let out = b.rx(ms(4), SDO_RX, &[0x2F, 0x00, 0x20, 0x00, 0x11, 0, 0, 0]);
    assert_eq!(out, [(0x585, ok_write(0x2000, 0))], "unchanged, no event");
    let out = b.rx(ms(5), SDO_RX, &[0x27, 0x02, 0x20, 0x00, 0x01, 0x02, 0x03, 0]);
    assert_eq!(
        out,
        [(TPDO1, vec![0x11, 0x22, 0x22, 0xB0, 0x03, 0x00, 0x00]), (0x585, ok_write(0x2002, 0))],
        "the trigger sends it unchanged"
    );
}

/// Calls the PDO part of its context at each SDO write of 0x2002 and keeps
/// the answers (a TPDO1 trigger, RPDO1's first object); `P` is its
/// `Application::PDO_CALLS`.
#[derive(Default)]
struct PdoCalls<const P: bool>(Vec<(bool, bool)>);

impl<const P: bool> Application for PdoCalls<P> {
    const PDO_CALLS: bool = P;

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, _sub: u8, by: Source) {
        if (index, by) == (0x2002, Source::Sdo) {
            self.0.push((ctx.trigger_tpdo(0), ctx.rpdo_object(0, 0).is_some()));
        }
    }
}

/// The identifiers of what a trigger of TPDO1 (type 254, Operational)
/// sends, and what the device's two PDO calls answered.
fn pdo_calls<const P: bool>() -> (Vec<u16>, Vec<(bool, bool)>) {
    let mut b: B<PdoCalls<P>> = Bench::new(Ram::new(ID), PdoCalls::default(), MemStorage::new(4096), ID);
    b.at(ms(0));
    assert_eq!(b.sdo_write(ID, 0x1800, 2, &[0xFE]), ok_write(0x1800, 2));
    b.nmt(0x01, ID);
    b.at(ms(1));
    let out = b.rx(ms(2), SDO_RX, &[0x27, 0x02, 0x20, 0x00, 0x01, 0x02, 0x03, 0]);
    assert_eq!(out.last(), Some(&(0x585, ok_write(0x2002, 0))));
    (out.iter().map(|f| f.0).collect(), std::mem::take(&mut b.node.app_mut().0))
}

#[test]
fn a_device_without_pdo_calls_gets_no_trigger_and_no_rpdo_object() {
    assert_eq!(pdo_calls::<true>(), (vec![TPDO1, 0x585], vec![(true, true)]));
    // `PDO_CALLS = false` (as `NoApplication`): the calls are not linked.
    assert_eq!(pdo_calls::<false>(), (vec![0x585], vec![(false, false)]), "no TPDO");
}

#[test]
fn the_change_of_state_tpdo_waits_for_its_inhibit_time() {
    let mut b = bench(Probe::default());
    // TPDO1 inhibit time 10 ms (100 × 100 µs), set while the PDO is invalid.
    assert_eq!(b.sdo_write(ID, 0x1800, 1, &[0x85, 0x01, 0x00, 0xC0]), ok_write(0x1800, 1));
    assert_eq!(b.sdo_write(ID, 0x1800, 3, &[100, 0]), ok_write(0x1800, 3));
    assert_eq!(b.sdo_write(ID, 0x1800, 1, &[0x85, 0x01, 0x00, 0x40]), ok_write(0x1800, 1));
    b.nmt(0x01, ID);
    assert_eq!(b.rx(ms(20), RPDO1, &[0x01, 0, 0, 0, 0, 0, 0, 0]), [(TPDO1, vec![0xFE, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44])]);
    assert_eq!(b.rx(ms(25), RPDO1, &[0x02, 0, 0, 0, 0, 0, 0, 0]), [], "inhibited");
    assert_eq!(b.run_until(ms(40)), [(ms(30), (TPDO1, vec![0xFD, 0x22, 0x22, 0x44, 0x44, 0x44, 0x44]))]);
}

/// Logs the NMT events of a device with node guarding (the b maXX 4400's dictionary).
#[derive(Default)]
struct Events(Vec<NmtEvent>);

impl Application for Events {
    fn on_nmt(&mut self, _ctx: &mut Ctx<'_>, event: NmtEvent) {
        self.0.push(event);
    }
}

#[test]
fn life_guarding_loss_reaches_the_device() {
    use firmware::devices::bmaxx4400::od::Ram as Bmaxx;
    let mut b: Bench<Bmaxx, Events, MemStorage, 4, 4, 0> = Bench::new(Bmaxx::new(ID), Events::default(), MemStorage::new(8192), ID);
    b.at(ms(0));
    // Guard time 100 ms, life time factor 2: the master guards once, then stops.
    assert_eq!(b.sdo_write(ID, 0x100C, 0, &[100, 0]), ok_write(0x100C, 0));
    assert_eq!(b.sdo_write(ID, 0x100D, 0, &[2]), ok_write(0x100D, 0));
    assert_eq!(b.rtr(ms(10), 0x705), [(0x705, vec![0x7F])]);
    b.node.app_mut().0.clear();
    b.run_until(ms(400));
    assert_eq!(b.node.app().0, [NmtEvent::CommunicationError(CommError::LifeGuarding)]);
}

/// Polled when due: logs the time of each poll, runs a 10 ms timer, and asks
/// for its timers with `Ctx::wake` from the RPDO's hook when 0x2100 sub 1 is
/// 1, and from the poll itself while `again` lasts.
#[derive(Default)]
struct WhenDue {
    polls: Vec<u64>,
    again: u32,
}

impl Application for WhenDue {
    const POLL_WHEN_DUE: bool = true;

    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, _by: Source) {
        if (index, sub) == (0x2100, 1) && ctx.read_u32(0x2100, 1) == Some(1) {
            ctx.wake();
        }
    }

    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let now = ctx.now().as_micros() / 1000;
        self.polls.push(now);
        if self.again > 0 {
            self.again -= 1;
            ctx.wake();
        }
        Some(ms(now + 10))
    }
}

#[test]
fn a_device_polled_when_due_runs_at_its_deadline_after_hooks_app_mut_and_its_own_wake() {
    let mut b: B<WhenDue> = Bench::new(Ram::new(ID), WhenDue::default(), MemStorage::new(4096), ID);
    let polls = |b: &B<WhenDue>| b.node.app().polls.clone();
    // The boot-up's hooks (reset, entering Pre-operational) bring polls until the node is up; then only the deadline does.
    b.at(ms(0));
    b.at(ms(1));
    let booted = polls(&b).len();
    for t in [2, 5, 10] {
        b.at(ms(t));
    }
    assert_eq!((polls(&b).len(), polls(&b).last()), (booted, Some(&1)), "not before its deadline");
    assert_eq!(b.node.process(ms(10)), Some(ms(11)), "its deadline is the node's");
    b.at(ms(11));
    assert_eq!(polls(&b).last(), Some(&11), "at its deadline");
    // An NMT command's hook (entering Operational): the same process polls.
    b.rx(ms(12), 0x000, &[0x01, ID]);
    assert_eq!(polls(&b).last(), Some(&12), "after a hook");
    // The RPDO's hook without a wake: not before the deadline; with one: at once.
    b.rx(ms(13), RPDO1, &[0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(polls(&b).last(), Some(&12), "an RPDO alone");
    b.rx(ms(14), RPDO1, &[0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(polls(&b).last(), Some(&14), "an RPDO whose hook asked");
    // An RPDO of the wrong length (its error goes to the device's NMT hook): at once.
    b.rx(ms(15), RPDO1, &[0x00, 0x00]);
    assert_eq!(polls(&b).last(), Some(&15), "an RPDO's length error");
    // app_mut: the next process polls; a poll that asks runs again at the next process.
    b.node.app_mut().again = 1;
    b.at(ms(16));
    b.at(ms(17));
    b.at(ms(18));
    assert_eq!(polls(&b).iter().rev().take(3).collect::<Vec<_>>(), [&17, &16, &15], "after app_mut, and once more as asked");
}

#[test]
fn after_an_rpdo_that_reaches_no_tpdo_the_node_wakes_for_its_event_timer() {
    // RPDO1 (0x2100 sub 1..4) is in no TPDO: the next process has nothing
    // to look at, only the event timer the frame started (50 ms) to wait for.
    let mut b: B<NoApplication> = Bench::new(Ram::new(ID), NoApplication, MemStorage::new(4096), ID);
    b.at(ms(0));
    assert_eq!(b.sdo_write(ID, 0x1400, 5, &[50, 0]), ok_write(0x1400, 5));
    b.nmt(0x01, ID);
    b.at(ms(1));
    assert_eq!(b.node.process(ms(2)), None, "no timer runs");
    let frame = canopen_core::frame::CanFrame::standard(RPDO1, &[1, 0, 2, 0, 3, 0, 4, 0]).expect("valid frame");
    b.node.on_frame(ms(10), &frame);
    assert_eq!(b.node.process(ms(10)), Some(ms(60)), "the RPDO's event timer");
    assert_eq!(b.node.process(ms(59)), Some(ms(60)));
    let out = b.at(ms(60));
    assert!(out.iter().any(|f| f.0 == 0x85 && f.1.get(..2) == Some(&[0x50, 0x82][..])), "EMCY 0x8250 RPDO timeout: {out:x?}");
}

/// Sets 0x2001 (UNSIGNED16, in TPDO1) to RPDO1's first object through the
/// image slot it found at reset application, as the CiA 402 profile sets its statusword.
#[derive(Default)]
struct Slotted {
    slot: canopen_core::node::ImageSlot,
}

impl Application for Slotted {
    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        if event == NmtEvent::ResetApplication {
            self.slot = ctx.image_slot(ctx.locate(0x2001, 0));
        }
    }

    fn rpdo_value(&mut self, ctx: &mut Ctx<'_>, at: canopen_core::od::EntryRef, value: u32, _len: u8) -> bool {
        if ctx.object_id(at) == Some((0x2100, 1)) {
            ctx.set_slot(self.slot, value);
            assert_eq!(ctx.slot_value(self.slot), value & 0xFFFF, "the slot holds what was set");
        }
        false
    }
}

#[test]
fn a_value_set_through_its_image_slot_sends_its_tpdo_when_it_changes_only() {
    let mut b: B<Slotted> = Bench::new(Ram::new(ID), Slotted::default(), MemStorage::new(4096), ID);
    b.at(ms(0));
    b.nmt(0x01, ID);
    let out = b.rx(ms(10), RPDO1, &[0x34, 0x12, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(out, [(TPDO1, vec![0x11, 0x34, 0x12, 0x44, 0x44, 0x44, 0x44])]);
    assert_eq!(b.sdo_upload(ID, 0x2001, 0), Ok(vec![0x34, 0x12]));
    // The same value again: no byte of TPDO1 changed.
    assert_eq!(b.rx(ms(20), RPDO1, &[0x34, 0x12, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]), []);
    let out = b.rx(ms(30), RPDO1, &[0x05, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00]);
    assert_eq!(out, [(TPDO1, vec![0x11, 0x05, 0x00, 0x44, 0x44, 0x44, 0x44])]);
}

#[test]
fn an_rpdo_frame_reaches_its_rpdo_only_where_every_check_of_the_dispatch_lets_it() {
    // The node takes the usual RPDO frame on a short path (the raw frame's
    // hook first, then in Operational straight to the RPDO): it must
    // answer as the full dispatch does.
    let mut b = bench(Probe::default());
    let frame = [0x0F, 0x00, 0x02, 0x00, 0x03, 0x00, 0x04, 0x00];
    let written = ["written 2100:1 Rpdo(0)", "written 2100:2 Rpdo(0)", "written 2100:3 Rpdo(0)", "written 2100:4 Rpdo(0)"];
    log(&mut b);
    assert_eq!(b.rx(ms(5), RPDO1, &frame), [], "Pre-operational: no PDO");
    assert_eq!(log(&mut b), Vec::<String>::new());
    b.nmt(0x01, ID);
    b.at(ms(6));
    log(&mut b);
    // SYNC moved onto RPDO1's COB-ID: the frame is a SYNC (without a
    // counter any length is one), not the RPDO.
    assert_eq!(b.sdo_write(ID, 0x1005, 0, &u32::from(RPDO1).to_le_bytes()), ok_write(0x1005, 0));
    log(&mut b);
    let out = b.rx(ms(10), RPDO1, &frame);
    // The synchronous TPDO2 goes out; TPDO1 carries 0x2000 as it was.
    assert_eq!(out, [(TPDO1, vec![0x11, 0x22, 0x22, 0x01, 0, 0, 0]), (0x285, vec![0xFB, 0xFF, 0xFF, 0xFF, 0, 0, 0xC0, 0x3F])]);
    assert_eq!(log(&mut b), ["sample"]);
    // SYNC back on 0x80: the RPDO.
    assert_eq!(b.sdo_write(ID, 0x1005, 0, &0x80u32.to_le_bytes()), ok_write(0x1005, 0));
    log(&mut b);
    b.rx(ms(20), RPDO1, &frame);
    assert_eq!(log(&mut b), written);
    // Stopped: no PDO.
    b.nmt(0x02, ID);
    log(&mut b);
    assert_eq!(b.rx(ms(30), RPDO1, &frame), []);
    assert_eq!(log(&mut b), Vec::<String>::new());
}
