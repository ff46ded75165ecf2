//! The device's side of a node: the hooks where devices differ, and the
//! context ([`Ctx`]) through which a hook reaches the dictionary, the time,
//! EMCY, raw frames and storage.
//!
//! Every hook runs on the node's own call ([`super::Node::on_frame`],
//! [`super::Node::process`] or an application request such as
//! [`super::Node::write_object`]), synchronously, so no event is lost and
//! the order is fixed: an RPDO writes 0x6040, [`Application::written`] runs
//! for it (and may update 0x6041 through the context), and the
//! change-of-state TPDO leaves in the same `process` (unless its inhibit time
//! holds it back).

use core::marker::PhantomData;

use crate::abort::AbortCode;
use crate::frame::CanFrame;
use crate::od::index;
use crate::od::{DataType, Dictionary, EntryRef};
use crate::services::nmt::NmtState;
use crate::services::pdo::TpdoRules;
use crate::services::pdo::map::Source as MapSource;
use crate::services::store::Scope;
use crate::storage::Storage;
use crate::time::{At, Instant};
use crate::wire::emcy::EmcyCode;
use crate::wire::time_stamp::TimeOfDay;

use super::controller::CanEmcyCodes;
use super::filter::AcceptanceList;
use super::router::SdoEffects;

/// Who put a value into the dictionary, as [`Application::written`] hears it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// An SDO download.
    Sdo,
    /// RPDO `n` (0-based), one call per mapped object.
    Rpdo(u8),
    /// The application, through [`super::Node::write_object`].
    App,
}

/// A communication error, reported whatever 0x1029 makes of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CommError {
    /// The heartbeat of this node-id (0x1016) timed out.
    Heartbeat(u8),
    /// The master stopped guarding this node (life guarding, 0x100C/0x100D).
    LifeGuarding,
    /// The CAN controller went bus-off (reported by the board).
    BusOff,
    /// RPDO `n` (0-based) missed its event timer (0x1400 + n sub 5).
    RpdoTimeout(u8),
    /// A frame of RPDO `n` (0-based) had a length other than its mapping's
    /// (each such frame; CiA 301's EMCY 0x8210 or 0x8220 is sent once): too
    /// short, it was not processed; too long, its mapped bytes were. A
    /// device with its own fault for it (a drive's "RPDO length error")
    /// reacts here; the others ignore it, as CiA 301 asks nothing more.
    RpdoLength(u8),
}

/// What the NMT state machine and error control tell the device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtEvent {
    /// The node entered this state (each change, so Operational → Stopped →
    /// Operational is three events, not one).
    Entered(NmtState),
    /// Reset application (and power-on): the application objects hold their
    /// defaults and the stored set. Reset communication follows.
    ResetApplication,
    /// Reset communication (and LSS "switch state global" to a new node-id):
    /// the services are configured, the node-id in [`Ctx::node_id`] is the active one.
    ResetCommunication,
    /// A communication error (even if 0x1029 asks for no state change).
    CommunicationError(CommError),
}

/// Where a device's manual departs from the strict CiA 301 reading of a
/// communication service. [`ServiceOptions::CIA301`] unless the device says otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServiceOptions {
    /// PDO mapping entries and COB-IDs may be rewritten while the PDO is
    /// valid and its mapping not empty, in Pre-operational only (abort
    /// 0x08000022 in Operational); writing sub 0 or entering Operational
    /// applies them. CiA 301 asks for the PDO invalid and sub 0 = 0 first.
    pub pdo_rewrite_while_valid: bool,
    /// Transmission type 254 is timer-only: sent when the event timer
    /// expires (or on a trigger or RTR), never on a change of the mapped data
    /// or on entering Operational. CiA 301 makes 254 event-driven, as 255.
    pub tpdo_254_timer_only: bool,
    /// Transmission type 255 with an event timer (not 0) is timer-only: a
    /// change of the mapped data sends it only while the timer is 0 (an
    /// encoder's "cyclic timer"). CiA 301 sends on both.
    pub tpdo_255_timer_only_with_timer: bool,
    /// Objects (an inclusive index range) that 0x1010 "save" leaves as they
    /// were stored: only the device's own command stores them
    /// ([`Ctx::save_objects`]).
    pub not_saved_by_1010: Option<(u16, u16)>,
    /// An object (sub 0) and a mask: when any of its bits is set at
    /// boot-up, the node enters Operational by itself, as 0x1F80 bit 2 does
    /// (an encoder's "start in Operational" in 0x6000 bit 14).
    pub start_operational: Option<(u16, u32)>,
    /// LSS "switch state global" to waiting after a new node-id was
    /// configured resets the node (application and communication) at once,
    /// where CiA 305 waits for an NMT reset (and starts only an unconfigured
    /// node, with reset communication).
    pub lss_start_resets_node: bool,
    /// A node-id that stands for "not configured" as CiA 305's 0xFF does
    /// (the EC5000's factory 127, L219): a node-id configured while it is
    /// active becomes active on leaving configuration, with reset
    /// communication, as CiA 305 starts an unconfigured node; from any
    /// other node-id it waits for an NMT reset.
    pub lss_unconfigured_node_id: Option<u8>,
    /// An object (sub 0) and a mask: when any of its bits is set at
    /// boot-up, the boot-up message is DS 301 V3's, an empty frame on
    /// 0x80 + node-ID and then eight zero bytes on it ("reset of the error
    /// register"), in place of 0x700 + node-ID with one zero byte.
    pub boot_up_v3: Option<(u16, u32)>,
    /// An object (sub 0) and a mask standing in for 0x1029 sub 1: a
    /// communication error (class 1: life guarding, heartbeat, a device's
    /// bus-off) enters Pre-operational when any of its bits is set, and
    /// changes no state when none is.
    pub communication_error_pre_operational: Option<(u16, u32)>,
}

impl ServiceOptions {
    /// The strict CiA 301 reading.
    pub const CIA301: ServiceOptions = ServiceOptions {
        pdo_rewrite_while_valid: false,
        tpdo_254_timer_only: false,
        tpdo_255_timer_only_with_timer: false,
        not_saved_by_1010: None,
        start_operational: None,
        lss_start_resets_node: false,
        lss_unconfigured_node_id: None,
        boot_up_v3: None,
        communication_error_pre_operational: None,
    };
}

/// The TPDO rules of a node with the application `A`: its timer-only
/// types ([`ServiceOptions`]' `tpdo_254_timer_only` and
/// `tpdo_255_timer_only_with_timer`), and change detection always on (the
/// node has no call that turns it off). Constants, so that a device
/// without them links none of their code.
pub struct OptionsOf<A: ?Sized>(PhantomData<fn() -> A>);

impl<A: Application + ?Sized> TpdoRules for OptionsOf<A> {
    const TYPE_254: bool = A::OPTIONS.tpdo_254_timer_only;
    const TYPE_255_WITH_TIMER: bool = A::OPTIONS.tpdo_255_timer_only_with_timer;
    // A node never calls `Pdos::set_change_detection`.
    const SWITCHES_CHANGE_DETECTION: bool = false;
}

// By hand: derived, they would ask `A` for them.
impl<A: ?Sized> Clone for OptionsOf<A> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<A: ?Sized> Copy for OptionsOf<A> {}

impl<A: ?Sized> core::fmt::Debug for OptionsOf<A> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("OptionsOf")
    }
}

/// The image bytes of a value the device sets or reads with every frame
/// ([`Ctx::image_slot`]): all zero bits, [`ImageSlot::NONE`], until found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImageSlot {
    offset: u16,
    /// 0: none.
    len: u8,
}

impl ImageSlot {
    /// No image bytes: [`Ctx::set_slot`] does nothing, [`Ctx::slot_value`] is 0.
    pub const NONE: ImageSlot = ImageSlot { offset: 0, len: 0 };
}

/// Raw frames one [`Ctx`] holds until the node queues them.
pub const RAW_BURST: usize = 4;

/// What a hook may touch of the node while it runs.
pub struct Ctx<'a> {
    pub(super) dict: &'static Dictionary,
    pub(super) image: &'a mut [u8],
    pub(super) services: &'a mut dyn super::comm::Services,
    pub(super) storage: &'a mut dyn Storage,
    pub(super) state: NmtState,
    /// The time of the call, since the node's epoch (`hook.epoch`).
    pub(super) now: At,
    pub(super) options: &'static ServiceOptions,
    pub(super) effects: SdoEffects,
    /// The node's side of the hook, borrowed whole (one pointer to build).
    pub(super) hook: &'a mut HookSide,
}

/// What a hook leaves for the node (raw frames, the wake) and the store
/// it may start: kept together in the node so that [`Ctx`] borrows them as one.
#[derive(Clone, Debug)]
// The count and the flags first, the frames last: shorter offsets on thumbv7m.
#[repr(C)]
pub(super) struct HookSide {
    pub(super) len: u8,
    /// The hook asked for the device's timers at the next process
    /// ([`Ctx::wake`]; here, not in [`Ctx`], whose size every hook call pays).
    pub(super) wake: bool,
    /// The active node-id: the node's own (here, where the hook's context
    /// reaches it through `hook`, so that building a [`Ctx`] for every
    /// hook call does not copy it).
    pub(super) node_id: u8,
    /// The node's store in stages (an SDO 0x1010/0x1011 in progress, or idle).
    pub(super) store: crate::services::store::Job,
    /// The node's epoch: the [`Instant`] (in µs) its [`At`]s count from
    /// (here, where the hook's context reaches it through `hook`, so that
    /// [`Ctx`] stays as small as it was).
    pub(super) epoch: u64,
    /// Raw frames sent by the hook, queued by the node when the hook returns
    /// (an SDO transfer holds the transmit queue while its hooks run).
    pub(super) frames: [CanFrame; RAW_BURST],
}

impl HookSide {
    /// Nothing left, no store; all zero bits.
    pub(super) const EMPTY: HookSide = HookSide {
        frames: [CanFrame::EMPTY; RAW_BURST],
        len: 0,
        wake: false,
        store: crate::services::store::Job::IDLE,
        epoch: 0,
        node_id: 0,
    };
}

impl Ctx<'_> {
    /// The time of the call that runs the hook.
    pub fn now(&self) -> Instant {
        // The epoch plus the call's `At`: the `Instant` the board gave, no overflow.
        Instant::from_micros(self.hook.epoch.wrapping_add(u64::from(self.now)))
    }

    /// The dictionary's entries (data types, access, lengths), for a device
    /// whose own protocol addresses objects by number.
    pub fn dictionary(&self) -> &'static Dictionary {
        self.dict
    }

    /// The active node-id.
    pub fn node_id(&self) -> u8 {
        self.hook.node_id
    }

    /// The NMT state.
    pub fn state(&self) -> NmtState {
        self.state
    }

    /// The value of (index, sub) as the dictionary holds it.
    pub fn read(&self, index: u16, sub: u8) -> Result<&[u8], AbortCode> {
        self.dict.read(self.image, index, sub)
    }

    /// An integer value of at most 32 bits (zero-extended), if (index, sub) exists.
    // Out of line: the profiles and devices read their parameters through
    // it at a dozen places or more (18 in the Sendix image, 19 in the
    // b maXX 4400's), each a copy of the context's loads and the `Option`.
    #[inline(never)]
    pub fn read_u32(&self, index: u16, sub: u8) -> Option<u32> {
        self.dict.read_u32(self.image, index, sub)
    }

    /// Writes (index, sub) as an SDO download would, with the dictionary's
    /// checks and the rules and side effects of the service that owns the
    /// object (a heartbeat time restarts the producer, a PDO parameter
    /// reconfigures the PDO). The device's own hooks do not run again for it.
    pub fn write_object(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        if index == index::STORE_PARAMETERS || index == index::RESTORE_DEFAULT_PARAMETERS {
            return self.store_command(index, sub, data, self.options, None);
        }
        let entry = self.precheck::<true>(index, sub, data)?;
        self.route_write(index, sub, data, entry, self.options.pdo_rewrite_while_valid)
    }

    /// Sets a value the device owns, read-only ones included (0x6041
    /// statusword, an "actual" node-id), without access checks or service
    /// side effects; the value must have the entry's length. A
    /// communication object set this way (0x1017, a PDO's parameters) is not
    /// applied to its service: use [`Ctx::write_object`] for those.
    // Out of line: a profile sets several values per sample (the sendix image was 300 B bigger inlined).
    #[inline(never)]
    pub fn set_value(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.effects.follow.written = true;
        self.dict.write_unchecked(self.image, index, sub, data)
    }

    /// An entry found once, for [`Ctx::read_at`] and [`Ctx::set_at`] on
    /// every frame without a dictionary search ([`EntryRef::NONE`] if the
    /// dictionary lacks it).
    pub fn locate(&self, index: u16, sub: u8) -> EntryRef {
        self.dict.locate(index, sub)
    }

    /// [`Ctx::read`] of an entry [`Ctx::locate`] found.
    #[inline(never)]
    pub fn read_at(&self, entry: EntryRef) -> Result<&[u8], AbortCode> {
        self.dict.read_entry(self.image, self.dict.entry(entry).ok_or(AbortCode::NoObject)?)
    }

    /// [`Ctx::set_value`] of an entry [`Ctx::locate`] found.
    // Out of line, as `set_value`.
    #[inline(never)]
    pub fn set_at(&mut self, entry: EntryRef, data: &[u8]) -> Result<(), AbortCode> {
        let entry = self.dict.entry(entry).ok_or(AbortCode::NoObject)?;
        // Only the TPDOs mapping its bytes look for a change, none if the value stayed the same.
        if self.dict.write_unchecked_entry(self.image, entry, data)? {
            self.effects.wrote_bytes(entry.offset, entry.len.into());
        }
        Ok(())
    }

    /// The image bytes of an entry [`Ctx::locate`] found (its first 4 at
    /// most), for [`Ctx::set_slot`] and [`Ctx::slot_value`] on every frame
    /// ([`ImageSlot::NONE`] for an entry the image does not hold: missing,
    /// constant or DOMAIN).
    // Out of line: it runs at reset application only.
    #[inline(never)]
    pub fn image_slot(&self, entry: EntryRef) -> ImageSlot {
        match self.dict.entry(entry) {
            Some(e) if !e.in_rom() && e.data_type != DataType::Domain => ImageSlot { offset: e.offset, len: e.len.min(4) },
            _ => ImageSlot::NONE,
        }
    }

    /// The value in the image bytes of `slot` (little-endian, zero-extended),
    /// as [`Ctx::rpdo_object`] gives it.
    // In line: a device reads its RPDOs' values through it with every frame.
    #[inline]
    pub fn slot_value(&self, slot: ImageSlot) -> u32 {
        let start = usize::from(slot.offset);
        let bytes = self.image.get(start..start.wrapping_add(usize::from(slot.len))).unwrap_or(&[]);
        // A match, as in `rpdo_object`: cheaper than a loop over the bytes.
        match *bytes {
            [a] => u32::from(a),
            [a, b] => u32::from(u16::from_le_bytes([a, b])),
            [a, b, c] => u32::from_le_bytes([a, b, c, 0]),
            [a, b, c, d] => u32::from_le_bytes([a, b, c, d]),
            _ => 0,
        }
    }

    /// [`Ctx::slot_value`] of a 2-byte slot (a controlword), without the
    /// length's dispatch: 0 for a slot of another length.
    #[inline]
    pub fn slot_u16(&self, slot: ImageSlot) -> u16 {
        let start = usize::from(slot.offset);
        match self.image.get(start..start.wrapping_add(usize::from(slot.len))) {
            Some(&[a, b]) => u16::from_le_bytes([a, b]),
            _ => 0,
        }
    }

    /// [`Ctx::set_at`] of a value the device sets with every frame (a
    /// statusword): the low bytes of `value` straight into the image bytes
    /// [`Ctx::image_slot`] found, without a look-up or a check of the entry.
    pub fn set_slot(&mut self, out: ImageSlot, value: u32) {
        let bytes = value.to_le_bytes();
        let start = usize::from(out.offset);
        let Some(slot) = self.image.get_mut(start..start.wrapping_add(usize::from(out.len))) else { return };
        let changed = match slot {
            // A statusword or a controlword: one compare.
            [a, b] => {
                let [lo, hi, ..] = bytes;
                let changed = (*a, *b) != (lo, hi);
                (*a, *b) = (lo, hi);
                changed
            }
            _ => {
                let mut changed = false;
                for (d, &s) in slot.iter_mut().zip(&bytes) {
                    changed |= *d != s;
                    *d = s;
                }
                changed
            }
        };
        // Only the TPDOs mapping its bytes look for a change, none if the value stayed the same.
        // `SdoEffects::wrote_bytes` in line: the first write of the hook names its bytes.
        if changed {
            if self.effects.wrote.1 == 0 {
                self.effects.wrote = (out.offset, u16::from(out.len));
            } else {
                self.effects.follow.written = true;
            }
        }
    }

    /// Raises an error: EMCY `code`, error register, 0x1003 (false if the
    /// error was already active or there is no room).
    pub fn raise_error(&mut self, code: EmcyCode, info: [u8; 5]) -> bool {
        self.effects.follow.services = true;
        self.services.emcy().raise(code, info)
    }

    /// Raises an error that sets the error register bits `register` (0x1001)
    /// while it lasts, beyond those its code's class sets.
    pub fn raise_error_with(&mut self, code: EmcyCode, register: u8, info: [u8; 5]) -> bool {
        self.effects.follow.services = true;
        self.services.emcy().raise_with(code, register, info)
    }

    /// Asks for a reset node (as NMT command 0x81), e.g. for program control
    /// 0x1F51 (CiA 302-3). Honoured from the hooks of an SDO write only, once
    /// its answer is queued (in the frame path, whose stack already holds an
    /// NMT reset; from the timers it would deepen the worst case).
    pub fn reset_node(&mut self) {
        self.effects.reset_node = true;
    }

    /// A serious error of 0x1029 class `class` (2 device profile, 3
    /// manufacturer specific) occurred: once the hook returns, the node
    /// changes state as that sub-index of 0x1029 says (0 Pre-operational
    /// if Operational, 1 no change, 2 Stopped), as it does for class 1 itself.
    pub fn error_behaviour(&mut self, class: u8) {
        self.effects.error_class = class;
    }

    /// Whether the error `code` is active (raised and not cleared): for a
    /// device that asks a fault's cause to be gone before its reset (a
    /// heartbeat or guarding loss, 0x8130, ends when it is back).
    pub fn error_active(&mut self, code: EmcyCode) -> bool {
        self.services.emcy().is_active(code)
    }

    /// Clears an error; the last one cleared sends "error reset".
    pub fn clear_error(&mut self, code: EmcyCode) {
        self.effects.follow.services = true;
        let emcy = self.services.emcy();
        emcy.clear(code);
        // No message when other errors stay active: 0x1001 follows at once.
        let register = emcy.register();
        let _ = self.dict.write_unchecked(self.image, index::ERROR_REGISTER, 0, &[register]);
    }

    /// Object `i` (in mapping order) of the mapping RPDO `n` uses: its
    /// entry ([`EntryRef::NONE`] for a dummy entry), the value the image
    /// holds for it (what the RPDO wrote; little-endian, zero-extended, its
    /// first 4 bytes) and its length. What [`Application::rpdo_written`]
    /// reports: the mapping was resolved when it was configured, so no
    /// dictionary search and no copy of the mapping. Always `None` for a
    /// device that says [`Application::PDO_CALLS`] `false`.
    pub fn rpdo_object(&self, n: u8, i: usize) -> Option<(EntryRef, u32, u8)> {
        let (at, slot) = self.services.rpdo_mapping(usize::from(n))?.object(i)?;
        let bytes = match slot.source {
            MapSource::Ram(offset) => self.image.get(usize::from(offset)..).unwrap_or(&[]),
            _ => &[],
        };
        // Not `od::le_u32` (a loop over the bytes): this match is 68
        // thumbv7m instructions cheaper on the CiA 402 row (measured).
        let value = match (slot.len, bytes) {
            (1, &[a, ..]) => u32::from(a),
            (2, &[a, b, ..]) => u32::from(u16::from_le_bytes([a, b])),
            (3, &[a, b, c, ..]) => u32::from_le_bytes([a, b, c, 0]),
            (_, &[a, b, c, d, ..]) => u32::from_le_bytes([a, b, c, d]),
            _ => 0,
        };
        Some((at, value, slot.len))
    }

    /// The (index, sub) of an entry (`None` for [`EntryRef::NONE`]).
    pub fn object_id(&self, at: EntryRef) -> Option<(u16, u8)> {
        self.dict.entry(at).map(|e| (e.index, e.sub))
    }

    /// Asks for [`Application::poll`] at the next [`super::Node::process`],
    /// before the deadline it last returned, without moving that deadline:
    /// for a device that polls when due ([`Application::POLL_WHEN_DUE`]),
    /// from the RPDO's or the raw frame's hook (the others bring the poll
    /// anyway) when it changed what its timers do, or from `poll` itself.
    pub fn wake(&mut self) {
        self.hook.wake = true;
    }

    /// Signals an application event for TPDO `n` (see [`super::Node::trigger_tpdo`]).
    /// Always `false` (nothing sent) for a device that says
    /// [`Application::PDO_CALLS`] `false`.
    pub fn trigger_tpdo(&mut self, n: usize) -> bool {
        self.effects.follow.written = true;
        self.services.trigger_tpdo(n)
    }

    /// Sends a frame outside CANopen (a foreign protocol). At most
    /// [`RAW_BURST`] per hook call; the node queues them when the hook
    /// returns, as long as the queue keeps [`super::RAW_RESERVE`] slots free
    /// for heartbeat, EMCY and SDO (a refused frame counts as a queue
    /// overflow, EMCY 0x8110). False if the burst is full, the frame is not
    /// a standard one of at most 8 bytes, or the device says
    /// [`Application::RAW_FRAMES`] `false` (nothing queues raw frames then).
    pub fn send_raw(&mut self, cob_id: u16, data: &[u8]) -> bool {
        match (CanFrame::standard(cob_id, data), self.hook.frames.get_mut(usize::from(self.hook.len))) {
            (Some(frame), Some(slot)) => {
                *slot = frame;
                // `get_mut` found the slot: `len` is below the burst's length.
                #[allow(clippy::arithmetic_side_effects)]
                {
                    self.hook.len += 1;
                }
                true
            }
            _ => false,
        }
    }

    /// Stores the objects of `first..=last` alone, as they are now: every
    /// other value keeps what was stored before (unsaved changes elsewhere
    /// stay unsaved). For a store the device's own command triggers (a
    /// preset stored when written, a "save bus parameters" object).
    /// Objects no stored set holds (read-only ones the device's build did
    /// not name as kept: od-gen's stored prefix) are refused with 0x08000020
    /// rather than stored as nothing.
    pub fn save_objects(&mut self, first: u16, last: u16) -> Result<(), AbortCode> {
        let job = crate::services::store::Job::save_objects(self.dict, first, last).map_err(super::router::store_abort)?;
        self.run_store(job)
    }

    /// The stored value of (index, sub) in the newest parameter set,
    /// read-only objects included ([`crate::services::store::stored_value`]):
    /// how a device gets back a value it keeps across power cycles itself.
    pub fn stored(&mut self, index: u16, sub: u8, buf: &mut [u8]) -> Option<usize> {
        crate::services::store::stored_value(self.dict, self.storage, self.hook.node_id, index, sub, buf)
    }

    /// Whether the parameters last saved were refused for this dictionary's
    /// layout (a firmware update changed it), so the node runs on its
    /// defaults ([`crate::services::store::refused`]): for a device that
    /// reports the loss, at reset application.
    pub fn stored_set_refused(&mut self) -> bool {
        crate::services::store::refused(self.dict, self.storage)
    }

    /// Whether the node's store in stages is in progress (an SDO 0x1010 or
    /// 0x1011, LSS "store configuration"): until it ends, the stores above
    /// are refused (0x08000022); from the first [`Application::poll`] after
    /// it, they work again. The hooks of its 0x1010/0x1011 write run while it does.
    pub fn storing(&self) -> bool {
        self.hook.store.busy()
    }

    /// Stores a scope as 0x1010 would (the device's
    /// [`ServiceOptions::not_saved_by_1010`] objects keep their stored values).
    pub fn save(&mut self, scope: Scope) -> Result<(), AbortCode> {
        self.run_store(self.save_job(scope))
    }

    /// Marks a scope for its defaults from the next reset on, as 0x1011 would.
    pub fn restore_defaults(&mut self, scope: Scope) -> Result<(), AbortCode> {
        self.run_store(crate::services::store::Job::restore(scope))
    }

    /// The node rebuilds its acceptance list (the identifiers
    /// [`Application::claim_ids`] lists have changed); nothing without
    /// [`Services::acceptance`](crate::od::Services::acceptance).
    pub fn refresh_acceptance(&mut self) {
        self.effects.follow.consumed_changed = true;
    }
}

/// The identifiers a device claims, for the node's acceptance list.
pub struct Claims<'a> {
    pub(super) list: &'a mut AcceptanceList,
}

impl Claims<'_> {
    /// Claims a data frame (`rtr` false) or a remote frame on `cob_id`.
    pub fn claim(&mut self, cob_id: u16, rtr: bool) {
        self.list.insert(cob_id, rtr);
    }
}

/// One object RPDO `n` wrote, with its value and mapped length (as
/// [`Ctx::rpdo_object`] gives them), offered to the device as the default
/// [`Application::rpdo_written`] does: [`Application::rpdo_value`] first,
/// then [`Application::written`] if it did not take it (dummy entries map
/// nothing). For a device that overrides `rpdo_written` to find the
/// objects its own way.
#[inline(always)]
pub fn rpdo_object_written<A: Application + ?Sized>(app: &mut A, ctx: &mut Ctx<'_>, n: u8, at: EntryRef, value: u32, len: u8) {
    if !app.rpdo_value(ctx, at, value, len)
        && let Some((index, sub)) = ctx.object_id(at)
        && index >= index::COMMUNICATION_AREA
    {
        app.written(ctx, index, sub, Source::Rpdo(n));
    }
}

/// Hooks a device implements; every method has a default, so a device
/// module overrides only what its manual asks for. The value lives in the
/// node, so a device type must be `const`-constructible and all zero bits
/// ([`crate::node`]).
pub trait Application {
    /// Where the device's manual departs from CiA 301.
    const OPTIONS: ServiceOptions = ServiceOptions::CIA301;

    /// The EMCY codes of the CAN controller's errors (and of frames that
    /// break the protocol), where the device's manual has its own.
    const CAN_EMCY: CanEmcyCodes = CanEmcyCodes::CIA301;

    /// The device stores parameters by a command of its own (a register, a
    /// manufacturer object) through [`Ctx::save`] or [`Ctx::save_objects`]:
    /// its stored set loads at every reset even when the dictionary has no
    /// 0x1010/0x1011 (which otherwise leave the store code out, `Services::storage`).
    const STORES: bool = false;

    /// [`Application::poll`] runs only when the deadline it last returned
    /// has come (`None`: none), after a hook (the RPDO's and the raw frame's
    /// only if they call [`Ctx::wake`]), after [`super::Node::app_mut`], or
    /// when the last poll called [`Ctx::wake`]; not at every
    /// [`super::Node::process`]. For a device whose timers depend only on
    /// time and on what its hooks and `app_mut` change.
    const POLL_WHEN_DUE: bool = false;

    /// The device overrides an SDO hook ([`Application::upload_size`],
    /// [`Application::read`], [`Application::download_check`],
    /// [`Application::write`], [`Application::check_write`] or
    /// [`Application::written`]). A device without them says `false`: the
    /// SDO servers' uploads, a download's checks and the downloads of the
    /// objects from 0x2000 on then reach the dictionary alone, and the
    /// hooks' context is built only for a download to a communication
    /// object (thumbv7m, the ds301-like bench: an expedited download of an
    /// application object 687 → 639 instructions; docs/benchmarks.md,
    /// "Round 16 (upl)"). Set `false` with a hook
    /// overridden, that hook is skipped for those transfers.
    const SDO_HOOKS: bool = true;

    /// [`super::Node::process`] has a short path: a call whose only work is
    /// the PDOs (an RPDO whose hook changed what an event-driven TPDO
    /// sends, a TPDO's timer) polls them alone, without the full call's
    /// checks of the other services: about 70 thumbv7m instructions fewer
    /// on such a call (the CiA 402 row), for 150 to 210 bytes of flash, and
    /// 5 instructions more on every other call that is not idle. For a
    /// device whose RPDOs drive its TPDOs (a drive). Frames and deadlines
    /// are the same either way (`tests/tests/process_short_path.rs`).
    const PDO_SHORT_PATH: bool = true;

    /// The device calls [`Ctx::trigger_tpdo`] or [`Ctx::rpdo_object`]
    /// (the default [`Application::rpdo_written`] does). A device that
    /// calls neither (it overrides `rpdo_written`, or has no RPDO) may say
    /// `false` (`NoApplication` does): the node then leaves their code out
    /// (about 100 bytes: the hooks reach the services through a vtable,
    /// which links every method, called or not). Set `false`,
    /// `trigger_tpdo` answers `false` and `rpdo_object` `None`.
    const PDO_CALLS: bool = true;

    /// The device sends frames outside CANopen ([`Ctx::send_raw`]). A
    /// device that never does may say `false` (`NoApplication` does): the
    /// node then leaves out the check for them after every hook call and
    /// the code that queues them (about 300 bytes in the reference images).
    /// Set `false`, `send_raw` answers `false` and sends nothing.
    const RAW_FRAMES: bool = true;

    /// Serve: the size of the value an upload of (index, sub) sends, if
    /// the device answers it instead of the dictionary (any index).
    fn upload_size(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8) -> Option<Result<usize, AbortCode>> {
        let _ = (ctx, index, sub);
        None
    }

    /// Serve: bytes `offset..` of a value the device answers (computed on read).
    fn read(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Option<Result<usize, AbortCode>> {
        let _ = (ctx, index, sub, offset, buf);
        None
    }

    /// Serve: checks a download the device takes before it starts (its own
    /// length rules: a 1-byte write to a 2-byte object).
    fn download_check(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, size: Option<usize>) -> Option<Result<(), AbortCode>> {
        let _ = (ctx, index, sub, size);
        None
    }

    /// Serve: a complete download the device takes instead of the
    /// dictionary (`Some`), typically writing other objects through
    /// [`Ctx::write_object`] (one write fanned out to several sub-indices).
    fn write(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Option<Result<(), AbortCode>> {
        let _ = (ctx, index, sub, data);
        None
    }

    /// Validate: a write to any object (communication objects included)
    /// that passed the dictionary's type, length and limit checks; an `Err`
    /// refuses it with that abort code and nothing changes.
    fn check_write(&mut self, ctx: &Ctx<'_>, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let _ = (ctx, index, sub, data);
        Ok(())
    }

    /// React: (index, sub) holds a new value, whoever wrote it.
    fn written(&mut self, ctx: &mut Ctx<'_>, index: u16, sub: u8, by: Source) {
        let _ = (ctx, index, sub, by);
    }

    /// RPDO `n` wrote its objects: by default, for each mapped object in
    /// mapping order ([`Ctx::rpdo_object`]: the mapping in use, resolved when
    /// it was configured, so no dictionary search), [`Application::rpdo_value`],
    /// and [`Application::written`] for those it did not take. A device no
    /// RPDO-written object concerns overrides it with nothing.
    fn rpdo_written(&mut self, ctx: &mut Ctx<'_>, n: u8) {
        for i in 0..crate::services::pdo::map::MAX_ENTRIES {
            let Some((at, value, len)) = ctx.rpdo_object(n, i) else { break };
            rpdo_object_written(self, ctx, n, at, value, len);
        }
    }

    /// One object an RPDO wrote, with the value it wrote (as
    /// [`Ctx::rpdo_object`] gives them): true if the device took it here,
    /// straight from the value, so that [`Application::written`] is not
    /// called for it. By default it takes none.
    fn rpdo_value(&mut self, ctx: &mut Ctx<'_>, at: EntryRef, value: u32, len: u8) -> bool {
        let _ = (ctx, at, value, len);
        false
    }

    /// Sample: a SYNC arrived or was produced; runs before the synchronous
    /// TPDOs are built, so they carry what this writes.
    fn sample(&mut self, ctx: &mut Ctx<'_>) {
        let _ = ctx;
    }

    /// Timers: runs at every [`super::Node::process`] (when due, with
    /// [`Application::POLL_WHEN_DUE`]); returns when the device wants to run
    /// again (folded into the node's deadline).
    fn poll(&mut self, ctx: &mut Ctx<'_>) -> Option<Instant> {
        let _ = ctx;
        None
    }

    /// An NMT or communication event.
    fn on_nmt(&mut self, ctx: &mut Ctx<'_>, event: NmtEvent) {
        let _ = (ctx, event);
    }

    /// A TIME frame arrived (0x1012).
    fn on_time(&mut self, ctx: &mut Ctx<'_>, time: TimeOfDay) {
        let _ = (ctx, time);
    }

    /// Raw frames: every received 11-bit frame first, whatever the NMT
    /// state (Initialising and an unconfigured node included). True if the
    /// device consumed it; the CANopen services then never see it.
    fn on_frame(&mut self, ctx: &mut Ctx<'_>, cob_id: u16, rtr: bool, data: &[u8]) -> bool {
        let _ = (ctx, cob_id, rtr, data);
        false
    }

    /// Raw frames: the identifiers [`Application::on_frame`] wants, added to
    /// the node's acceptance list (the board's filter passes them). Not
    /// called without [`Services::acceptance`](crate::od::Services::acceptance):
    /// the filter then passes every frame.
    fn claim_ids(&self, dict: &'static Dictionary, image: &[u8], claims: &mut Claims<'_>) {
        let _ = (dict, image, claims);
    }

    /// False switches the CANopen services off: no boot-up, no NMT, no
    /// SDO, no PDO, no heartbeat; only the device's raw frames and timers run.
    fn canopen(&self) -> bool {
        true
    }
}

/// A device with no hooks: the dictionary answers everything.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoApplication;

impl Application for NoApplication {
    const SDO_HOOKS: bool = false;
    // No hook makes a TPDO from an RPDO: the bytes, not the short path.
    const PDO_SHORT_PATH: bool = false;
    // Its `rpdo_written` does nothing, and no hook triggers a TPDO.
    const PDO_CALLS: bool = false;
    // No hook sends a raw frame.
    const RAW_FRAMES: bool = false;

    fn rpdo_written(&mut self, ctx: &mut Ctx<'_>, n: u8) {
        let _ = (ctx, n);
    }
}
