//! The node's side of LSS (CiA 305): where the configuration is stored, how
//! a configured node-id becomes active, and the timing of "activate bit
//! timing". The protocol itself is [`crate::services::lss`].

use crate::services::lss::{LssAction, Mode, UNCONFIGURED};
use crate::services::store::StoredSet;
use crate::storage::Storage;
use crate::time::{At, NEVER, at_by, later, ms_span, shift};
use crate::wire::lss::SLAVE_COB_ID;

use super::{Application, Node};
use crate::od::ObjectDictionary;
use crate::od::index;

/// A bit-rate table index from its node field (index + 1, 0 for none).
fn rate_index(field: u16) -> Option<u8> {
    field.checked_sub(1).and_then(|index| u8::try_from(index).ok())
}

/// The board's side of LSS "activate bit timing": the CAN controller.
pub trait BitRateControl {
    /// Switches the controller to CiA 305 bit-timing table index `index`
    /// (0 = 1 Mbit/s … 8 = 10 kbit/s), or 0xFF when a master activates bit
    /// timing it never configured (the node's "no rate": a board keeps its
    /// rate, as `hal-host` and the images do).
    fn set_bit_rate(&mut self, index: u8);
}

/// The LSS bit-rate switch: silent until `at`, then switch (first phase) or
/// resume (second phase). CiA 305 §5.2.3. Not an `Option` in the node: its
/// `None` would not be all zero bits ([`crate::node`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Switch {
    index: u8,
    /// The switch delay in µs.
    delay: u32,
    at: At,
    phase: Phase,
}

/// Where a [`Switch`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// No switch in progress.
    Off,
    /// The first delay: silent at the old rate.
    Silent,
    /// The second delay: silent at the new rate.
    Switched,
}

impl Switch {
    /// No switch in progress.
    pub(super) const OFF: Switch = Switch { index: 0, delay: 0, at: 0, phase: Phase::Off };

    /// The epoch moved by `by` µs.
    pub(super) fn shift(&mut self, by: u64) {
        shift(&mut self.at, at_by(by));
    }

    /// Whether the node stays silent for a switch.
    pub(super) fn active(&self) -> bool {
        self.phase != Phase::Off
    }
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// At power-on: a stored LSS configuration (in `stored`, the newest
    /// valid set) overrides the default node-id and gives the bit rate.
    pub(super) fn load_lss_configuration(&mut self, stored: Option<StoredSet>) {
        let dict = self.od.dictionary();
        if !O::SERVICES.lss || !dict.device.lss_supported {
            return;
        }
        // No rate (0xFF) unless one is stored: the unpowered node has none
        // (`bit_rate` 0), and power-on is once.
        let mut rate = 0xFF;
        if let Some((node_id, bit_rate)) = stored.and_then(|set| set.lss()) {
            if (1..=127).contains(&node_id) || node_id == UNCONFIGURED {
                self.hook.node_id = node_id;
            }
            if bit_rate != 0xFF {
                self.bit_rate = u16::from(bit_rate) + 1;
            }
            rate = bit_rate;
        }
        // The unpowered slave is waiting with no sequence begun; the address
        // follows 0x1018 at the reset that follows (`refresh_lss`).
        self.lss.power_on(self.hook.node_id, rate, dict.device.baud_rates);
        self.lss_active = true;
    }

    /// The LSS address follows 0x1018 sub 1..4 (after a reset or a new serial number).
    pub(super) fn refresh_lss(&mut self) {
        if !self.lss_supported() {
            return;
        }
        let Node { od, lss, .. } = self;
        let (dict, image) = (od.dictionary(), od.image());
        // A loop, not four calls: each inlined its own `read_u32`. Into the
        // slave's own array: no copy on the stack to zero and move.
        for (part, sub) in lss.address_mut().iter_mut().zip(1u8..) {
            *part = dict.read_u32(image, index::IDENTITY, sub).unwrap_or(0);
        }
    }

    /// A frame on 0x7E5. Cold: LSS runs at commissioning, not in
    /// operation, and out of the main loop it leaves the frame paths the
    /// inliner's budget (ds301 -496 B, ds301-lean -456, ec5000 -152 of flash;
    /// the interop image +228, where the budget went to other code).
    #[cold]
    pub(super) fn lss_request(&mut self, now: At, data: &[u8]) {
        // The dispatch calls this only for a node that runs an LSS slave (`lss_on`).
        let lss = &mut self.lss;
        let Ok(request) = <&[u8; 8]>::try_from(data) else {
            self.counters.count_malformed();
            return;
        };
        let configuring = lss.mode() == Mode::Configuration;
        let action = lss.on_request(request);
        // Configuration left for waiting with a new node-id pending: only "switch state global"
        // to waiting does that, and it leaves both node-ids as they were, so they are compared after it.
        if action == LssAction::None && configuring && lss.mode() == Mode::Waiting && lss.pending_node_id() != lss.active_node_id() {
            // A device that resets itself on leaving configuration with a new node-id (the Sendix, L3567).
            if A::OPTIONS.lss_start_resets_node {
                self.reset_application();
                return;
            }
            // A device whose own "unconfigured" node-id is active (the EC5000's 127) starts the new one so.
            if A::OPTIONS.lss_unconfigured_node_id.is_some_and(|id| id == lss.active_node_id()) {
                self.reset_communication();
                return;
            }
        }
        match action {
            LssAction::None => {}
            LssAction::Malformed => self.counters.count_malformed(),
            LssAction::Answer(answer) => {
                self.push(SLAVE_COB_ID, &answer.bytes());
            }
            LssAction::ActivateBitTiming { delay_ms, index } => {
                let delay = ms_span(delay_ms);
                // Frames queued at the old rate are dropped: they would leave at the new one.
                self.txq.clear();
                self.switch = Switch { index, delay, at: later(now, delay), phase: Phase::Silent };
            }
            // In stages; without storage (`Services::storage`) the answer is "storage failed".
            LssAction::Store { node_id, bit_rate } => self.store_lss(node_id, bit_rate),
            LssAction::Start(node_id) => {
                self.hook.node_id = node_id;
                if A::OPTIONS.lss_start_resets_node {
                    self.reset_application();
                } else {
                    self.reset_communication();
                }
            }
        }
    }

    /// Runs the bit-rate switch; returns its next deadline.
    pub(super) fn process_switch(&mut self, now: At) -> At {
        if !O::SERVICES.lss {
            return NEVER;
        }
        let sw = &mut self.switch;
        match sw.phase {
            Phase::Off => return NEVER,
            _ if now < sw.at => return sw.at,
            Phase::Switched => {
                sw.phase = Phase::Off;
                return NEVER;
            }
            Phase::Silent => {}
        }
        sw.phase = Phase::Switched;
        sw.at = later(now, sw.delay);
        let (index, at) = (sw.index, sw.at);
        let rate = u16::from(index) + 1;
        self.bit_rate = rate;
        self.bit_rate_request = rate;
        at
    }

    /// Whether the node runs an LSS slave, from the dictionary's constants
    /// alone: a constant in a generated image, where `lss_on` loads and tests
    /// the node's flag. Power-on sets that flag from the same two, so after it
    /// the two agree. It serves the paths that run only after power-on (the
    /// reset's stages, the acceptance list) or whose result nothing reads
    /// before it (a serial number set before power-on refreshes an address
    /// that the power-on's reset reads again). The frame path keeps
    /// `lss_on`: an unpowered node answers no LSS request.
    pub(super) fn lss_supported(&self) -> bool {
        O::SERVICES.lss && self.od.dictionary().device.lss_supported
    }

    /// Whether the node runs an LSS slave: `false` at compile time for a
    /// dictionary without LSS, so its code is left out.
    pub(super) fn lss_on(&self) -> bool {
        O::SERVICES.lss && self.lss_active
    }

    /// The bit-rate table index (CiA 305: 0 = 1 Mbit/s … 8 = 10 kbit/s) the
    /// node runs at, if a stored configuration or LSS set one (0xFF after an
    /// activation without a configured rate, as the board was told).
    pub fn bit_rate(&self) -> Option<u8> {
        rate_index(self.bit_rate)
    }

    /// A bit rate the board must switch its CAN controller to now (once).
    pub fn take_bit_rate_change(&mut self) -> Option<u8> {
        self.stale = true;
        rate_index(core::mem::take(&mut self.bit_rate_request))
    }

    /// Hands a pending bit-rate change to the controller; call it after
    /// [`Node::process`]. Returns whether the rate changed.
    pub fn apply_bit_rate(&mut self, controller: &mut impl BitRateControl) -> bool {
        self.stale = true;
        match rate_index(core::mem::take(&mut self.bit_rate_request)) {
            Some(index) => {
                controller.set_bit_rate(index);
                true
            }
            None => false,
        }
    }

    /// Sets 0x1018 sub 4 (the serial number, part of the LSS address), which
    /// only the device knows; it holds over every reset.
    pub fn set_serial_number(&mut self, serial: u32) {
        self.stale = true;
        self.serial = Some(serial);
        let dict = self.od.dictionary();
        let _ = dict.write_unchecked(self.od.image_mut(), index::IDENTITY, 4, &serial.to_le_bytes());
        self.refresh_lss();
    }

    /// The LSS state, if the node supports LSS.
    pub fn lss_mode(&self) -> Option<Mode> {
        self.lss_on().then(|| self.lss.mode())
    }
}
