//! The node: owns the dictionary and every service, routes each received
//! frame by COB-ID, runs the timers, and queues what it sends.
//!
//! Sans-IO and interrupt-friendly: [`Node::on_frame`] does bounded work (a
//! handful of identifier compares, then one service; never a scan of the
//! dictionary), [`Node::process`] runs the timers and returns the next
//! deadline, and [`Node::transmit`] hands out queued frames in CAN priority
//! order. Nothing is global: any number of nodes can live in one process.
//!
//! This module holds the type, its constructors and accessors; the work is
//! in `reset` (power-on, reset application and communication), `dispatch`
//! ([`Node::on_frame`]), `state` (NMT state changes, communication errors),
//! `process` ([`Node::process`]), `sinks` (where services send), `router`
//! (SDO access to the dictionary), `lss`, `filter` (acceptance list),
//! `controller` (CAN controller events → EMCY) and `comm` (the
//! communication services and their configuration).
//!
//! # All zero bits, so the node lies in `.bss`
//!
//! A firmware image builds its node at compile time, in a `static`
//! ([`Node::unpowered`] is a `const fn`), and powers it on where it lies,
//! so no node-sized value is ever built on the stack and copied (as it is
//! when [`Node::new`] returns one). The static lies in `.bss`, cleared at
//! start-up and free in flash, only if every byte of the unpowered node is
//! zero: one field that is not moves the whole node, kilobytes, to `.data`,
//! where it takes its size in flash too. So every state the node holds
//! (the services', the profiles', a device's [`Application`], the storage
//! a board gives it, a zeroed `Ram`) has a `const` value before power-on
//! that is all zero bits. The rule shapes the data:
//!
//! - no `Option` whose `None` is not zero: a value with a `bool` beside it
//!   (the LSS slave, the LSS switch, a heartbeat consumer's last state,
//!   CiA 406's scaling), or `Option<NonZero…>` (the SDO server's timeout);
//! - flags that are usually `true` negated (a TPDO's `no_change_detection`,
//!   the acceptance list's `overflowed`);
//! - 0 for "not configured": COB-ID 0 (NMT's, never a PDO's or SYNC's)
//!   until the first configuration, sequence number 0 for a free slot of the
//!   transmit queue, the zero variant first in an enum (a PDO mapping's
//!   `Dummy` source);
//! - a `const` start value per type (`UNCONFIGURED`, `NEW`, `EMPTY`, `ZERO`)
//!   apart from `Default`, which is what a dictionary without the object
//!   gives.
//!
//! `cargo xtask build` holds every image to it: the node's static must be
//! in `.bss`, and `.data` at most 256 bytes.

mod app;
mod comm;
mod controller;
mod dispatch;
mod filter;
mod lss;
mod objects;
mod process;
mod reset;
mod router;
mod sinks;
mod state;
mod store;

pub use app::{
    Application, Claims, CommError, Ctx, ImageSlot, NmtEvent, NoApplication, OptionsOf, RAW_BURST, ServiceOptions, Source,
    rpdo_object_written,
};
pub use comm::{Comm, EMCY_SLOTS, ErrorBehaviour};
pub use controller::{CanEmcyCodes, ControllerEvent, TRANSIENT_ERROR_HOLD};
pub use filter::{ACCEPTANCE_CAPACITY, AcceptanceList, AcceptedId};
pub use lss::BitRateControl;

use crate::abort::AbortCode;
use crate::frame::CanFrame;
use crate::od::ObjectDictionary;
use crate::services::lss::LssSlave;
use crate::services::nmt::{Nmt, NmtState};
use crate::services::pdo::ALL_TPDOS;
use crate::services::sdo_server::SdoServers;
use crate::storage::Storage;
use crate::time::{self, At, Instant, REBASE};
use crate::txq::TxQueue;
use crate::wire::emcy::EmcyCode;

/// Frames the transmit queue holds.
pub const TX_QUEUE: usize = 32;
/// Bytes an SDO download may carry (127 block segments of 7 bytes, rounded).
/// One buffer serves every SDO server of the node (see [`SdoServers`]).
pub const SDO_BUFFER: usize = 896;
/// SDO servers a node runs unless its type says otherwise: the default
/// server (0x1200) and three further ones (0x1201–0x1203). A server whose
/// parameter object the dictionary lacks, or whose COB-IDs are not valid,
/// stays off; each costs about 80 bytes of RAM, the download buffer is shared.
pub const SDO_SERVERS: usize = 4;
/// When a device that polls when due ([`Application::POLL_WHEN_DUE`]) is
/// polled next: at the next [`Node::process`] ([`PollDue::NOW`], all zero
/// bits: any hook but the RPDO's unless it calls [`Ctx::wake`], and
/// [`Node::app_mut`], set it), or once the deadline its last poll returned
/// has come. The deadline is kept as bytes: a field aligned to 1 leaves the
/// offsets of the node's other fields as they are (an `Option<Instant>`
/// moved them and made the sendix image, which does not poll when due, 540
/// bytes bigger).
#[derive(Clone, Copy, Debug)]
struct PollDue {
    /// False: at the next process.
    waits: bool,
    /// The deadline [an [`At`], little-endian]; [`time::NEVER`]: none.
    at: [u8; 4],
}

impl PollDue {
    const NOW: PollDue = PollDue { waits: false, at: [0; 4] };

    /// After a poll that returned `deadline` (and asked again with [`Ctx::wake`] if `wake`).
    fn after(deadline: At, wake: bool) -> PollDue {
        PollDue { waits: !wake, at: deadline.to_le_bytes() }
    }

    /// `Some(deadline to report)` while the poll is not due at `now`.
    fn skip(self, now: At) -> Option<At> {
        let at = At::from_le_bytes(self.at);
        (self.waits && now < at).then_some(at)
    }

    /// The epoch moved by `by` µs.
    fn shift(&mut self, by: u64) {
        let mut at = At::from_le_bytes(self.at);
        time::shift(&mut at, time::at_by(by));
        self.at = at.to_le_bytes();
    }
}

/// Queue slots a device's raw frames ([`Ctx::send_raw`]) leave free for
/// heartbeat, EMCY and SDO answers.
pub const RAW_RESERVE: usize = 8;

/// What the node counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Frames received.
    pub rx: u32,
    /// Frames handed to the controller.
    pub tx: u32,
    /// Frames for this node that broke their service's format (counted, then ignored).
    pub malformed: u32,
    /// Frames no service of this node consumes in its state.
    pub ignored: u32,
}

/// The counters are diagnostics: each wraps at `u32::MAX` (a reader takes
/// differences), so no count can overflow.
impl Counters {
    /// One frame received.
    fn count_rx(&mut self) {
        self.rx = self.rx.wrapping_add(1);
    }

    /// One frame ignored.
    fn count_ignored(&mut self) {
        self.ignored = self.ignored.wrapping_add(1);
    }

    /// One malformed frame.
    fn count_malformed(&mut self) {
        self.malformed = self.malformed.wrapping_add(1);
    }
}

/// A CANopen slave.
///
/// `R`, `T` and `HB` are the RPDO, TPDO and heartbeat-consumer counts of the
/// dictionary (its generated `RPDO_COUNT`, `TPDO_COUNT`, `HB_CONSUMER_COUNT`).
/// `SDO` is the number of SDO servers (0x1200, 0x1201, …) the node runs, at
/// least the dictionary's `SDO_SERVER_COUNT` to serve all of them;
/// [`SDO_SERVERS`] unless given.
// Per-frame flags and deadlines first (thumbv7m's 2-byte loads reach 32 B for a byte, 128 for a word), buffers and dictionary RAM last.
#[repr(C)]
pub struct Node<
    O: ObjectDictionary,
    A: Application,
    S: Storage,
    const R: usize,
    const T: usize,
    const HB: usize,
    const SDO: usize = SDO_SERVERS,
> {
    nmt: Nmt,
    /// Something beyond PDO data and SDO transfers changed since the last
    /// full [`Node::process`] (a frame for NMT, heartbeat, SYNC or LSS, a
    /// reset, a state change, an error, a communication object written):
    /// the next one runs every service again instead of answering from
    /// `core_deadline`.
    stale: bool,
    /// The last [`Node::process`] left nothing to do before `next` (no SDO
    /// transfer, no EMCY waiting): until then, and unless `stale` or
    /// `touched` say otherwise, the next one only runs the device's timers.
    quiet: bool,
    boot_pending: bool,
    /// The node starts itself (0x1F80, [`ServiceOptions::start_operational`])
    /// once its boot-up message has left: TPDOs would overtake it in the priority queue.
    start_pending: bool,
    lss_active: bool,
    /// The low byte of [`Counters::tx`] + 1 when a call last asked to be
    /// called again at once (0: never, as all zero bits; `Node::due_again`).
    tx_mark: u8,
    /// The reset in progress, if any (`reset`).
    reset: reset::Stage,
    /// The bit-rate table index in use + 1, if known (stored or switched by
    /// LSS); 0 if not. One halfword store where an `Option<u8>` took two
    /// byte stores, none is zero bits (the unpowered node's), and a `u16`
    /// keeps index 0xFF (switched to with no rate configured) apart from none.
    bit_rate: u16,
    /// A bit-rate change the board has not applied yet: its index + 1, or 0.
    bit_rate_request: u16,
    /// Bit t: the RAM image may have changed under TPDO t since it last
    /// compared its data (change-of-state detection runs only then, not on
    /// every call, and only for the TPDOs a write can change).
    touched: u32,
    /// The earliest deadline of every service but the SDO servers and the
    /// PDOs, as the last full [`Node::process`] found it (0 before the
    /// first: due, and all zero bits).
    core_deadline: At,
    /// The node's own deadline (without the device's) as the last
    /// [`Node::process`] returned it, made earlier by what happened since
    /// (read only while `quiet`, which the first `process` sets).
    next: At,
    /// The earliest deadline of every service but the PDOs and the SDO
    /// servers (the core services, EMCY, the CAN controller) as the last
    /// [`Node::process`] left it; 0 (never before it) in a state without
    /// PDOs and before the first call. While `quiet` and not `stale`, a
    /// call before it has only PDO work (`Node::process_pdos`).
    others_next: At,
    reported_overflows: u32,
    /// The transmit queue's overflow count when no TPDO was left waiting to
    /// retry a refused frame: a TPDO waits only after the queue refused it,
    /// which counts an overflow, so while the count is the same no TPDO
    /// waits and the PDOs need not be walked for it (`Node::retrying`).
    retry_free_at: u32,
    /// A serial number the board reports, written to 0x1018 sub 4 at every reset.
    serial: Option<u32>,
    /// For a device that polls when due ([`Application::POLL_WHEN_DUE`]):
    /// when its next [`Application::poll`] is due.
    app_due: PollDue,
    /// The answer that goes out when it ends, if any.
    store_answer: store::StoreAnswer,
    /// COB-IDs (client→server, server→client) of each SDO server, if valid.
    sdo_cob_ids: [Option<(u16, u16)>; SDO],
    storage: S,
    /// The LSS bit-rate switch, if one is in progress.
    switch: lss::Switch,
    /// The newest stored set the reset in progress found.
    reset_stored: Option<crate::services::store::StoredSet>,
    /// The CAN controller's errors (`controller`).
    controller: controller::ControllerErrors,
    counters: Counters,
    app: A,
    /// What a device hook left (raw frames, the wake) and the store in
    /// progress, a stage per [`Node::process`] call (`store`): borrowed
    /// whole by every hook's [`Ctx`].
    hook: app::HookSide,
    comm: comm::Hooked<A, O, R, T, HB>,
    txq: TxQueue<TX_QUEUE>,
    sdo: SdoServers<SDO_BUFFER, SDO>,
    /// The LSS slave, in use when `lss_active` (the dictionary says
    /// `LSS_Supported`; set at power-on). Not an `Option`: its `None` would
    /// not be all zero bits (see the module docs).
    lss: LssSlave,
    /// The identifiers the node consumes, for the board's acceptance filter.
    acceptance: filter::AcceptanceList,
    od: O,
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Powers the node on: loads the stored parameters, resets application
    /// and communication, and queues the boot-up message for the first
    /// [`Node::process`]. [`Node::unpowered`], then [`Node::power_on`].
    pub fn new(od: O, app: A, storage: S, node_id: u8, now: Instant) -> Self {
        let mut node = Self::unpowered(od, app, storage);
        node.power_on(node_id, now);
        node
    }

    /// A node before power-on: it stays in Initialising, ignores every
    /// frame and sends nothing until [`Node::power_on`] gives it its
    /// default node-id. `od`'s contents do not matter (power-on resets the
    /// whole image).
    ///
    /// A `const fn`, and what it builds besides `od`, `app` and `storage`
    /// is all zero bits, so a firmware image's node lies in `.bss` (see the
    /// module docs).
    pub const fn unpowered(od: O, app: A, storage: S) -> Self {
        Node {
            od,
            app,
            storage,
            nmt: Nmt::new(),
            comm: comm::Hooked::new(),
            sdo: SdoServers::new(),
            sdo_cob_ids: [None; SDO],
            txq: TxQueue::new(),
            counters: Counters { rx: 0, tx: 0, malformed: 0, ignored: 0 },
            boot_pending: false,
            start_pending: false,
            touched: 0,
            stale: false,
            core_deadline: 0,
            quiet: false,
            next: 0,
            others_next: 0,
            reported_overflows: 0,
            tx_mark: 0,
            retry_free_at: 0,
            lss: LssSlave::new([0; 4], 0, 0, 0),
            lss_active: false,
            serial: None,
            bit_rate: 0,
            switch: lss::Switch::OFF,
            bit_rate_request: 0,
            acceptance: filter::AcceptanceList::new(),
            hook: app::HookSide::EMPTY,
            controller: controller::ControllerErrors::new(),
            reset: reset::Stage::Idle,
            reset_stored: None,
            store_answer: store::StoreAnswer::NONE,
            app_due: PollDue::NOW,
        }
    }

    /// The node-id.
    pub fn node_id(&self) -> u8 {
        self.hook.node_id
    }

    /// The NMT state.
    pub fn state(&self) -> NmtState {
        self.nmt.state()
    }

    /// The dictionary (the generated `Ram` with its typed accessors).
    pub fn od(&self) -> &O {
        &self.od
    }

    /// The dictionary, for the application to write without any check or
    /// hook (use [`Node::write_object`] for a write with the services'
    /// rules); change-of-state TPDOs see the new values at the next [`Node::process`].
    pub fn od_mut(&mut self) -> &mut O {
        self.touched = ALL_TPDOS;
        &mut self.od
    }

    /// Signals an application event for TPDO `n` (0-based; transmission
    /// types 0, 254, 255): it goes out at the next [`Node::process`] (type
    /// 0 at the next SYNC), inhibit time permitting. False if that TPDO is
    /// not valid or of another type.
    pub fn trigger_tpdo(&mut self, n: usize) -> bool {
        self.touched = ALL_TPDOS;
        self.comm.pdos.trigger(n)
    }

    /// Writes (index, sub) for the application, as an SDO download would:
    /// the dictionary's checks, the device's validation, the owning
    /// service's rules and side effects, then [`Application::written`] with
    /// [`Source::App`]. Change-of-state TPDOs see it at the next [`Node::process`].
    pub fn write_object(&mut self, now: Instant, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let now = self.tick(now);
        self.with_app_cold(now, |app, ctx| {
            router::Router { ctx, app, by: Source::App, od: core::marker::PhantomData::<O>, staged: None }
                .write_with_hooks(index, sub, data)
        })
    }

    /// The CAN controller went bus-off (the board reports it): the device
    /// hears [`CommError::BusOff`].
    pub fn bus_off(&mut self, now: Instant) {
        let now = self.tick(now);
        self.bus_off_at(now);
    }

    /// [`Node::bus_off`] at `now`.
    pub(super) fn bus_off_at(&mut self, now: At) {
        self.stale = true;
        self.with_app_cold(now, |app, ctx| app.on_nmt(ctx, NmtEvent::CommunicationError(CommError::BusOff)));
    }

    /// `now` as an [`At`], since the node's epoch: once that is [`REBASE`]
    /// µs behind, the epoch moves to `now` first ([`Node::rebase`]). Every
    /// call from the board goes through here before a service sees the time.
    #[inline(always)]
    pub(super) fn tick(&mut self, now: Instant) -> At {
        // A clock that stepped back wraps to a large `since`: the epoch moves back to `now`.
        let since = now.as_micros().wrapping_sub(self.hook.epoch);
        if since < u64::from(REBASE) {
            since as At
        } else {
            self.rebase(now);
            0
        }
    }

    /// Moves the epoch to `now`: every deadline and moment the services
    /// hold moves back by as much, one already past to 0 (past it stays),
    /// so that each keeps its distance to `now` and none is ever read
    /// across a wrap. Once per 35.8 minutes at most, or after a board did
    /// not call for longer (a deadline it missed is then due). A clock
    /// that stepped back moves nothing: the deadlines wait out the step.
    /// Without CANopen (a device's [`Application::canopen`]) no service
    /// has a deadline to move.
    // Out of line, but not `#[cold]`: cold, the compiler laid the calls'
    // set-up out again around it (ds301 196 bytes more, ds301-lean 30, ec5000
    // 76; unitek-ds 56 bytes less, sendix 132, bmaxx4400 92, agile 44).
    #[inline(never)]
    fn rebase(&mut self, now: Instant) {
        let by = now.as_micros().saturating_sub(self.hook.epoch);
        self.hook.epoch = now.as_micros();
        if self.app.canopen() {
            self.comm.shift(by, O::SERVICES.guarding);
            self.sdo.shift(by);
            self.switch.shift(by);
            // The folded deadlines (`core_deadline`, `next`, `others_next`)
            // are asked again: the next call runs every service.
            self.stale = true;
            self.quiet = false;
        }
        // Read only by a device that polls when due (the others' is never consulted).
        if A::POLL_WHEN_DUE {
            self.app_due.shift(by);
        }
    }

    /// A deadline as the board takes it.
    // A wrapping add: the epoch is a moment the board's clock showed, and a
    // u64 of microseconds is 584,000 years away from wrapping (the saturating
    // add cost every `process` its carry checks).
    #[inline(always)]
    fn instant_of(&self, deadline: At) -> Option<Instant> {
        (deadline != time::NEVER).then(|| Instant::from_micros(self.hook.epoch.wrapping_add(u64::from(deadline))))
    }

    /// Runs `f` with the device's hooks and their context, then queues the
    /// raw frames they sent and follows up what their writes changed.
    // Inlined: for a hook the device leaves at its default, nothing of it remains.
    #[inline(always)]
    pub(super) fn with_app<V>(&mut self, now: At, f: impl FnOnce(&mut A, &mut Ctx<'_>) -> V) -> V {
        let mut wake = false;
        let (value, effects) = self.run_hook(now, |app, ctx| {
            let value = f(app, ctx);
            if A::POLL_WHEN_DUE {
                wake = core::mem::take(&mut ctx.hook.wake);
            }
            value
        });
        // The raw frame's hook (every frame) leaves the device's timers to their deadline unless it asked for them.
        if wake {
            self.poll_app_next();
        }
        self.queue_raw();
        self.follow_sdo(effects);
        if effects.error_class != 0 {
            self.device_error(effects.error_class, now);
        }
        value
    }

    /// [`Node::with_app`] for every hook but the RPDO's and the raw frame's
    /// (NMT events, TIME, bus-off, the SYNC sample, the device's timers, an
    /// application's write): what follows the hook is one out-of-line call
    /// instead of a copy at each site (about 17 thumbv7m instructions more
    /// per call, 200 bytes less in a drive image).
    #[inline(always)]
    pub(super) fn with_app_cold<V>(&mut self, now: At, f: impl FnOnce(&mut A, &mut Ctx<'_>) -> V) -> V {
        let (value, effects) = self.run_hook(now, f);
        // The hook may have changed what the device's timers do: they run at the next process.
        if A::POLL_WHEN_DUE {
            (self.app_due.waits, self.hook.wake) = (false, false);
        }
        if Self::FOLD_HOOKS {
            self.queue_raw();
            self.follow_sdo(effects);
            if effects.error_class != 0 {
                self.device_error(effects.error_class, now);
            }
        } else {
            self.after_cold_hook(now, effects);
        }
        value
    }

    /// [`Node::with_app_cold`] for the RPDO's hook (every received RPDO):
    /// the follow-up in line (the raw frames' and the writes' checks; only
    /// what they find is called), the device error checked here: two calls
    /// less than `after_cold_hook` on the path of every frame. The
    /// device's timers are left to the caller, which takes the hook's
    /// [`Ctx::wake`] and decides whether they wait.
    #[inline(always)]
    pub(super) fn with_app_follow<V>(&mut self, now: At, f: impl FnOnce(&mut A, &mut Ctx<'_>) -> V) -> V {
        if Self::FOLD_HOOKS {
            return self.with_app_cold(now, f);
        }
        let (value, effects) = self.run_hook(now, f);
        self.queue_raw();
        self.follow_sdo(effects);
        if effects.error_class != 0 {
            self.device_error(effects.error_class, now);
        }
        value
    }

    /// A device without state (a zero-sized application, `NoApplication`)
    /// mostly leaves the hooks at their defaults, whose follow-up folds away
    /// inline; for the others an out-of-line follow-up is smaller. Either
    /// does the same.
    const FOLD_HOOKS: bool = core::mem::size_of::<A>() == 0;

    #[inline(never)]
    fn after_cold_hook(&mut self, now: At, effects: router::SdoEffects) {
        self.follow_hook(effects);
        if effects.error_class != 0 {
            self.device_error(effects.error_class, now);
        }
    }

    /// The raw frames a hook sent queued, its writes followed up.
    #[inline(never)]
    fn follow_hook(&mut self, effects: router::SdoEffects) {
        self.queue_raw();
        self.follow_sdo(effects);
    }

    /// The hook `f` with its context; what it changed beyond its writes.
    #[inline(always)]
    fn run_hook<V>(&mut self, now: At, f: impl FnOnce(&mut A, &mut Ctx<'_>) -> V) -> (V, router::SdoEffects) {
        let Node { od, app, storage, comm, nmt, hook, .. } = self;
        let dict = od.dictionary();
        let mut ctx = Ctx {
            dict,
            image: od.image_mut(),
            services: comm,
            storage,
            state: nmt.state(),
            now,
            options: &A::OPTIONS,
            effects: router::SdoEffects::default(),
            hook,
        };
        let value = f(app, &mut ctx);
        (value, ctx.effects)
    }

    /// [`Node::with_app`] for a node resetting (Initialising), where a
    /// device error changes no state: the 0x1029 class the hook reported
    /// (0: none) is returned, not followed, so that no state change is
    /// reachable from the reset's stages (the stack estimate counts every
    /// call the code holds, taken or not). The follow-up as in
    /// [`Node::with_app_cold`].
    #[inline(always)]
    pub(super) fn with_app_resetting<V>(&mut self, now: At, f: impl FnOnce(&mut A, &mut Ctx<'_>) -> V) -> (V, u8) {
        let (value, effects) = self.run_hook(now, f);
        self.poll_app_next();
        if Self::FOLD_HOOKS {
            self.queue_raw();
            self.follow_sdo(effects);
        } else {
            self.follow_hook(effects);
        }
        (value, effects.error_class)
    }

    /// Queues the device's raw frames, keeping [`RAW_RESERVE`] slots free; a
    /// frame that does not fit counts as an overflow (EMCY 0x8110).
    #[inline(always)]
    pub(super) fn queue_raw(&mut self) {
        // A device without raw frames: none to queue, and no code for them.
        if A::RAW_FRAMES && self.hook.len != 0 {
            self.queue_raw_frames();
        }
    }

    fn queue_raw_frames(&mut self) {
        let n = usize::from(core::mem::take(&mut self.hook.len));
        for f in self.hook.frames.iter().take(n) {
            if self.txq.free() > RAW_RESERVE {
                self.txq.push(*f);
            } else {
                self.txq.count_overflow();
            }
        }
    }

    /// The device's hooks.
    pub fn app(&self) -> &A {
        &self.app
    }

    /// The device's hooks, mutably (its next [`Node::process`] polls it:
    /// what changed here may change what its timers do).
    pub fn app_mut(&mut self) -> &mut A {
        self.poll_app_next();
        &mut self.app
    }

    /// For a device that polls when due ([`Application::POLL_WHEN_DUE`]):
    /// its next [`Node::process`] polls it, whatever its deadline (something
    /// changed what its timers do).
    #[inline(always)]
    fn poll_app_next(&mut self) {
        if A::POLL_WHEN_DUE {
            self.app_due.waits = false;
        }
    }

    /// The storage.
    pub fn storage_mut(&mut self) -> &mut S {
        &mut self.storage
    }

    /// Frame counters.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// Frames refused by the full transmit queue.
    pub fn tx_overflows(&self) -> u32 {
        self.txq.overflows()
    }

    /// The COB-IDs (client→server, server→client) SDO server `i` (0-based:
    /// 0 is 0x1200) uses, or `None` if it is off.
    pub fn sdo_cob_ids(&self, i: usize) -> Option<(u16, u16)> {
        self.sdo_cob_ids.get(i).copied().flatten()
    }

    /// The communication services (for inspection in tests and tools).
    pub fn comm(&self) -> &Comm<R, T, HB, OptionsOf<A>> {
        &self.comm
    }

    /// Raises an application error: EMCY with `code`, error register, 0x1003.
    pub fn raise_error(&mut self, code: EmcyCode, info: [u8; 5]) {
        self.stale = true;
        self.comm.emcy.raise(code, info);
    }

    /// Clears an application error; the last one cleared sends "error reset".
    pub fn clear_error(&mut self, code: EmcyCode) {
        self.stale = true;
        self.comm.emcy.clear(code);
    }

    /// The next frame to send, highest priority first.
    // In line: its one caller in an image is the `CanNode` trampoline, and
    // a burst of TPDOs takes a call per frame (5 per SYNC of the bench).
    #[inline(always)]
    pub fn transmit(&mut self) -> Option<CanFrame> {
        // LSS "activate bit timing": silent from the request until the second delay ends.
        if self.switch.active() || self.txq.is_empty() {
            return None;
        }
        // The last frame: a drained queue lets the node start itself and ends a queue overflow.
        if self.txq.len() == 1 && (self.start_pending || self.comm.emcy.tx_overflow_active()) {
            self.stale = true;
        }
        self.counters.tx = self.counters.tx.wrapping_add(1);
        self.txq.pop()
    }

    /// Puts back a frame the controller could not send (it goes out first).
    pub fn requeue(&mut self, frame: CanFrame) {
        self.stale = true;
        if self.txq.push_front(frame) {
            self.counters.tx = self.counters.tx.wrapping_sub(1);
        }
    }

    /// Queues a data frame of the node's own (boot-up, heartbeat, EMCY,
    /// SYNC, LSS, guarding): false if refused (`data` longer than 8 bytes, an
    /// identifier above 0x7FF, or the queue full, which counts an overflow).
    // Through `push_data`, the PDOs' and SDO servers' way into the queue: no
    // `CanFrame` built and copied, and its bytes past `data` zero as
    // `CanFrame::standard` left them. A byte loop: `copy_from_slice` linked
    // a `memcpy` call (ds301 102 B more).
    fn push(&mut self, cob_id: u16, data: &[u8]) -> bool {
        let mut buf = [0u8; 8];
        for (d, s) in buf.iter_mut().zip(data) {
            *d = *s;
        }
        data.len() <= 8 && self.txq.push_data(cob_id, &buf, data.len() as u8)
    }
}

#[cfg(test)]
mod tests {
    use super::Counters;

    #[test]
    fn the_frame_counters_wrap() {
        let mut c = Counters { rx: u32::MAX, tx: 7, malformed: u32::MAX, ignored: u32::MAX };
        c.count_rx();
        c.count_malformed();
        c.count_ignored();
        assert_eq!(c, Counters { rx: 0, tx: 7, malformed: 0, ignored: 0 });
    }
}
