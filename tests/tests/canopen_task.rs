//! The CANopen task's work as the images run it (`firmware::runner`), on
//! the Sendix dictionary (node 0x3F, no heartbeat, TPDO1 = 0x6004 event-driven):
//! NMT states reach the application one by one, an application request is
//! answered and its frames leave in the step that follows it (the task
//! steps after every request, with no timer due), and what the
//! controller's interrupts counted becomes EMCY.

use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::node::{AcceptanceList, BitRateControl, NoApplication};
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Instant;
use canopen_core::wire::emcy::EmcyCode;
use embedded_can::Frame;
use firmware::boards::qemu::ram_storage::RamStorage;
use firmware::boards::region_size;
use firmware::can_node::CanNode;
use firmware::devices::sendix;
use firmware::runner::{Controller, ControllerStatus, Reply, Request, Runner, StateQueue, Value};

type Storage = RamStorage<{ region_size(sendix::od::STORED_SIZE) }>;

const ID: u8 = 0x3F;
const TPDO1: u16 = 0x1BF;
const EMCY: u16 = 0x0BF;

fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

/// A controller that takes every frame and records what it was asked.
#[derive(Default)]
struct Bus {
    sent: Vec<(u16, Vec<u8>)>,
    lists: Vec<u32>,
    bit_rates: Vec<u8>,
}

impl BitRateControl for Bus {
    fn set_bit_rate(&mut self, index: u8) {
        self.bit_rates.push(index);
    }
}

impl Controller for Bus {
    fn send(&mut self, node: &mut dyn CanNode) {
        while let Some(f) = node.transmit() {
            self.sent.push((f.cob_id().expect("11-bit"), f.data().to_vec()));
        }
    }

    fn set_acceptance(&mut self, list: &AcceptanceList) {
        self.lists.push(list.generation());
    }
}

struct Task {
    node: sendix::od::Node<NoApplication, Storage>,
    runner: Runner,
    bus: Bus,
    states: StateQueue<8>,
}

impl Task {
    /// Powered on at 0 and stepped once: the boot-up left.
    fn new() -> Self {
        let node = sendix::od::Node::new(sendix::od::Ram::new(ID), NoApplication, Storage::default(), ID, ms(0));
        let mut task = Task { node, runner: Runner::new(), bus: Bus::default(), states: StateQueue::new() };
        assert_eq!(task.step(0), [(0x73F, vec![0x00])]);
        task
    }

    /// One step at `t`: what went to the bus.
    fn step(&mut self, t: u64) -> Vec<(u16, Vec<u8>)> {
        self.runner.step(&mut self.node, ms(t), &mut self.bus, &mut self.states);
        std::mem::take(&mut self.bus.sent)
    }

    fn frame(&mut self, t: u64, cob_id: u16, data: &[u8]) {
        let frame = CanFrame::standard(cob_id, data).expect("frame");
        self.runner.on_frame(&mut self.node, ms(t), &frame, &mut self.states);
    }

    fn request(&mut self, request: Request) -> Reply {
        self.runner.on_request(&mut self.node, request)
    }

    fn states(&mut self) -> Vec<NmtState> {
        std::iter::from_fn(|| self.states.pop()).collect()
    }
}

#[test]
fn every_nmt_state_reaches_the_application() {
    let mut task = Task::new();
    assert_eq!(task.states(), [NmtState::PreOperational]);
    // Three NMT commands handled in one wake-up of the task, before its step.
    task.frame(1, 0x000, &[0x01, ID]);
    task.frame(1, 0x000, &[0x02, ID]);
    task.frame(1, 0x000, &[0x01, ID]);
    assert_eq!(task.states(), [NmtState::Operational, NmtState::Stopped, NmtState::Operational]);
    task.step(1);
    assert_eq!(task.states(), [], "no change in the step");
    // Reset node: Initialising, then pre-operational once the boot-up left.
    task.frame(2, 0x000, &[0x81, ID]);
    assert!(task.node.resetting());
    // One step runs every stage of the reset (a `process` call each) and sends the boot-up.
    assert_eq!(task.step(2), [(0x73F, vec![0x00])]);
    assert!(!task.node.resetting());
    assert_eq!(task.states(), [NmtState::Initialising, NmtState::PreOperational]);
    assert_eq!(task.states.lost(), 0);
}

#[test]
fn requests_are_answered_and_their_frames_leave_in_the_next_step() {
    let mut task = Task::new();
    task.frame(1, 0x000, &[0x01, ID]);
    assert_eq!(task.step(1), [(TPDO1, vec![0, 0, 0, 0]), (0x3BF, vec![0, 0, 0, 0])], "entering Operational");
    assert_eq!(task.node.process(ms(2)), None, "no timer: only a frame or a request wakes the task");

    // 0x6004 Position value is read-only for the bus, not for the device.
    let position = Value::new(&0x0001_E240u32.to_le_bytes()).expect("4 bytes");
    assert_eq!(task.request(Request::Write { index: 0x6004, sub: 0, value: position }), Reply::Done);
    assert_eq!(task.step(3), [(TPDO1, vec![0x40, 0xE2, 0x01, 0x00])], "change of state");
    assert_eq!(task.request(Request::Read { index: 0x6004, sub: 0 }), Reply::Value(position));
    assert_eq!(task.step(4), []);

    assert_eq!(task.request(Request::TriggerTpdo(0)), Reply::Done);
    assert_eq!(task.step(5), [(TPDO1, vec![0x40, 0xE2, 0x01, 0x00])], "an application event sends it unchanged");
    assert_eq!(task.request(Request::TriggerTpdo(7)), Reply::NotTriggered, "no TPDO8");

    assert_eq!(task.request(Request::RaiseError { code: EmcyCode(0xFF01), info: [1, 2, 3, 4, 5] }), Reply::Done);
    // Generic + manufacturer-specific bits in the error register.
    assert_eq!(task.step(6), [(EMCY, vec![0x01, 0xFF, 0x81, 1, 2, 3, 4, 5])]);
    assert_eq!(task.request(Request::ClearError(EmcyCode(0xFF01))), Reply::Done);
    assert_eq!(task.step(7), [(EMCY, vec![0; 8])], "error reset");
}

#[test]
fn refused_requests_carry_the_abort_code() {
    let mut task = Task::new();
    let one = Value::new(&[1]).expect("1 byte");
    assert_eq!(task.request(Request::Write { index: 0x2FFF, sub: 0, value: one }), Reply::Refused(AbortCode::NoObject));
    assert_eq!(
        task.request(Request::Read { index: 0x1000, sub: 0 }),
        // 0x000B0196: CiA 406, multi-turn absolute (the manual's M5868 column, docs/devices/sendix.md D2).
        Reply::Value(Value::new(&[0x96, 0x01, 0x0B, 0x00]).expect("4 bytes"))
    );
    // 0x1008 "Kuebler Sendix Encoder" does not fit a request's 8 bytes.
    assert_eq!(task.request(Request::Read { index: 0x1008, sub: 0 }), Reply::Refused(AbortCode::LengthTooHigh));
    assert_eq!(task.request(Request::Read { index: 0x1000, sub: 1 }), Reply::Refused(AbortCode::NoSubIndex));
    assert_eq!(task.step(1), [], "nothing to send");
}

#[test]
fn what_the_interrupts_counted_becomes_emcy() {
    let mut task = Task::new();
    let status = ControllerStatus::new();
    for _ in 0..3 {
        status.rx_overrun();
    }
    status.set_error_passive(true);
    task.runner.controller_events(&mut task.node, ms(10), &status);
    assert_eq!(task.step(10), [(EMCY, vec![0x10, 0x81, 0x11, 3, 0, 0, 0, 0]), (EMCY, vec![0x20, 0x81, 0x11, 0, 0, 0, 0, 0])]);
    task.runner.controller_events(&mut task.node, ms(20), &status);
    assert_eq!(task.step(20), [], "nothing new");
    // Two recoveries before the task ran are one event.
    status.bus_off_recovered();
    status.bus_off_recovered();
    status.set_error_passive(false);
    task.runner.controller_events(&mut task.node, ms(30), &status);
    assert_eq!(task.step(30), [(EMCY, vec![0x40, 0x81, 0x11, 1, 0, 0, 0, 0])], "error active: 0x8120 cleared, others still active");
    assert_eq!(status.rx_overruns(), 3);
}

#[test]
fn the_controller_gets_the_acceptance_list_when_it_changes() {
    let mut task = Task::new();
    assert_eq!(task.bus.lists.len(), 1, "at the first step");
    task.step(1);
    assert_eq!(task.bus.lists.len(), 1, "unchanged");
    // SYNC moves from 0x080 to 0x081 (0x1005).
    let before = task.node.acceptance().clone();
    assert!(before.accepts(0x080, false));
    task.frame(2, 0x63F, &[0x23, 0x05, 0x10, 0x00, 0x81, 0, 0, 0]);
    assert_eq!(task.step(2), [(0x5BF, vec![0x60, 0x05, 0x10, 0x00, 0, 0, 0, 0])]);
    assert!(task.node.acceptance().accepts(0x081, false) && !task.node.acceptance().accepts(0x080, false));
    assert_eq!(task.bus.lists, [before.generation(), task.node.acceptance().generation()]);
    assert!(task.bus.bit_rates.is_empty());
}
