//! Power-on and the NMT resets. Reset application restores the
//! application part of the dictionary (defaults, then the stored set) and
//! goes on with reset communication, which restores the communication part
//! and reconfigures every service from the image. Power-on is both, after
//! the stored LSS configuration.

use crate::id::CobId;
use crate::od::ObjectDictionary;
use crate::od::index;
use crate::services::lss::UNCONFIGURED;
use crate::services::nmt::Nmt;
use crate::services::pdo::ALL_TPDOS;
use crate::services::store::{self, Part, StoredSet};
use crate::storage::Storage;
use crate::time::{At, Instant};

use super::{Application, NmtEvent, Node, RAW_BURST};

/// A reset in progress. NMT reset node and reset communication do their
/// work a stage per [`Node::process`] call, so that no call does all of it
/// (docs/firmware.md, "Longest step"); the node is Initialising until the
/// call of the last stage queues the boot-up, as CiA 301 §7.3.2.2.1 asks.
/// The stages run in the order declared ([`Stage::next`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub(super) enum Stage {
    /// No reset in progress (zero bits: the unpowered node's).
    Idle,
    /// Finds the newest stored set (a CRC over it), then resets communication.
    FindThenCommunication,
    /// The newer set was broken: checks the older one (a second CRC, in a
    /// call of its own), then resets communication.
    FindOlderThenCommunication,
    /// Finds the newest stored set, then resets the application (the
    /// stages from here to `Application` are a reset that includes it).
    FindThenApplication,
    /// The same with the older set.
    FindOlderThenApplication,
    /// The application part of the image: defaults, then the stored set.
    Application,
    /// The communication part of the image: defaults, then the stored set;
    /// then the communication services but the PDOs configured from it (in
    /// one stage: 13,509 thumbv7m instructions with a stored set at the end
    /// of round 17, the node's longest call, well below the 20,000 that
    /// issue 12 allows; a stage of their own cost ds301-lean 10 B).
    Communication,
    /// The RPDOs configured from the image.
    Rpdos,
    /// The TPDOs configured from the image; then LSS, SDO servers and the
    /// acceptance list, and the boot-up is due.
    Tpdos,
}

/// The stage after each one (Idle after the last), by its number: the
/// order as data, one load, where a match compiled to a second jump table.
static NEXT: [Stage; 9] = [
    Stage::Idle,          // Idle
    Stage::Communication, // FindThenCommunication
    Stage::Communication, // FindOlderThenCommunication
    Stage::Application,   // FindThenApplication
    Stage::Application,   // FindOlderThenApplication
    Stage::Communication, // Application
    Stage::Rpdos,         // Communication
    Stage::Tpdos,         // Rpdos
    Stage::Idle,          // Tpdos
];

impl Stage {
    /// The stage after this one (Idle after the last).
    fn next(self) -> Stage {
        NEXT.get(self as usize).copied().unwrap_or(Stage::Idle)
    }
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize, const SDO: usize>
    Node<O, A, S, R, T, HB, SDO>
{
    /// Powers on a node from [`Node::unpowered`], where it lies, with
    /// `node_id` as its default node-id: loads the stored parameters (an
    /// LSS configuration overrides `node_id`), resets application and
    /// communication, and queues the boot-up message for the first
    /// [`Node::process`]. Once per node; a running node restarts through
    /// NMT reset node instead.
    pub fn power_on(&mut self, node_id: u8, now: Instant) {
        let now = self.tick(now);
        self.hook.node_id = node_id;
        if !A::RAW_FRAMES {
            // Nothing queues raw frames (`queue_raw`): a full burst makes
            // `Ctx::send_raw` refuse every one, as the constant says.
            self.hook.len = RAW_BURST as u8;
        }
        if !O::SERVICES.acceptance {
            // No list is kept: one that is not complete makes a board's
            // filter pass every frame ([`Node::acceptance`]).
            self.acceptance.overflowed = true;
        }
        // The reset's check of the stored sets serves the LSS configuration
        // too, which it loads before the reset takes the node-id. Not
        // `begin_reset`: the unpowered node's NMT is Initialising and no
        // boot-up or start is pending (all zero bits), and power-on is once.
        self.reset = Stage::FindThenApplication;
        while Self::LOADS_STORED && self.reset != Stage::Application {
            self.reset_step(now);
        }
        self.reset = Stage::Application;
        self.load_lss_configuration(self.reset_stored.filter(|_| Self::LOADS_STORED));
        self.complete_reset(now);
    }

    /// Whether the node loads stored sets: the dictionary's 0x1010/0x1011
    /// (`Services::storage`) or the device's own store command (`Application::STORES`).
    const LOADS_STORED: bool = O::SERVICES.storage || A::STORES;

    /// The newer (or `older`) stored set checked ([`store::check`]); none
    /// on a node without storage, which then links no store code.
    fn check_stored(&mut self, older: bool) -> Result<Option<StoredSet>, ()> {
        if Self::LOADS_STORED { store::check(self.od.dictionary(), &mut self.storage, older) } else { Ok(None) }
    }

    /// A part of the image from its defaults and the stored set found (a
    /// node without storage links no store code: the defaults alone).
    fn reset_part(&mut self, part: Part) {
        let (dict, image) = (self.od.dictionary(), self.od.image_mut());
        // A dictionary without application values (both of its ranges
        // empty): that part has nothing to restore, and no call is linked
        // (the bounds are the dictionary's constants).
        if part == Part::Application
            && dict.comm_len == dict.stored_len
            && dict.stored_len.saturating_add(dict.comm_rest) >= dict.defaults.len
        {
            return;
        }
        if Self::LOADS_STORED {
            store::reset_part(dict, image, self.hook.node_id, &mut self.storage, self.reset_stored.as_ref(), part);
        } else if part == Part::Communication {
            dict.reset_communication(image, self.hook.node_id);
        } else {
            dict.reset_application(image, self.hook.node_id);
        }
    }

    /// Starts reset application (and then communication): see [`Stage`].
    pub(super) fn reset_application(&mut self) {
        self.begin_reset(true);
    }

    /// Starts reset communication: see [`Stage`].
    pub(super) fn reset_communication(&mut self) {
        self.begin_reset(false);
    }

    /// The node is Initialising from here on; a reset that includes the
    /// application stays one if a reset communication interrupts it.
    pub(super) fn begin_reset(&mut self, application: bool) {
        let application =
            application || matches!(self.reset, Stage::FindThenApplication | Stage::FindOlderThenApplication | Stage::Application);
        self.reset = if application { Stage::FindThenApplication } else { Stage::FindThenCommunication };
        self.nmt = Nmt::new();
        self.boot_pending = false;
        self.start_pending = false;
    }

    /// Whether a reset is in progress: [`Node::process`] carries it on, a
    /// stage per call, and returns `now` as its deadline until it is done.
    pub fn resetting(&self) -> bool {
        self.reset != Stage::Idle
    }

    /// Runs a reset at once (power-on). A reset a frame started runs from
    /// [`Node::process`] only: the device's reset hooks then run on its
    /// stack path, not on a second one (the worst-case stack estimate adds
    /// every path a device hook can start, docs/firmware.md "Stack").
    fn complete_reset(&mut self, now: At) {
        while self.reset != Stage::Idle {
            self.reset_step(now);
        }
    }

    /// One stage of the reset in progress. The next stage is set before the
    /// device's hooks run, so a reset they ask for starts over cleanly. Out
    /// of line: the stages' locals and the device's reset hooks take a
    /// frame of their own, not one on top of all of `process`'s.
    #[inline(never)]
    pub(super) fn reset_step(&mut self, now: At) {
        let stage = self.reset;
        self.reset = stage.next();
        let dict = self.od.dictionary();
        match stage {
            Stage::Idle => {}
            Stage::FindThenApplication
            | Stage::FindThenCommunication
            | Stage::FindOlderThenApplication
            | Stage::FindOlderThenCommunication => {
                let older = matches!(stage, Stage::FindOlderThenApplication | Stage::FindOlderThenCommunication);
                match self.check_stored(older) {
                    Ok(set) if Self::LOADS_STORED => self.reset_stored = set,
                    // Without storage nothing is ever found: `reset_stored` stays `None`.
                    Ok(_) => {}
                    // A broken newer set: the older one in a call of its own.
                    // (Only the newer set's check fails: `stage` is a `FindThen…`.)
                    Err(()) => {
                        let application = stage == Stage::FindThenApplication;
                        self.reset = if application { Stage::FindOlderThenApplication } else { Stage::FindOlderThenCommunication };
                    }
                }
            }
            Stage::Application => self.reset_application_part(now),
            Stage::Communication => {
                // CiA 305: a node-id configured by LSS becomes active here.
                if self.lss_supported() {
                    self.hook.node_id = self.lss.reset_communication();
                }
                self.reset_part(Part::Communication);
                if let Some(serial) = self.serial {
                    let _ = dict.write_unchecked(self.od.image_mut(), index::IDENTITY, 4, &serial.to_le_bytes());
                }
                self.comm.configure(dict, self.od.image(), now);
            }
            Stage::Rpdos => self.comm.configure_pdos(dict, self.od.image(), false),
            Stage::Tpdos => {
                // Timer-only types are `A::OPTIONS`' constants (`OptionsOf`).
                self.comm.configure_pdos(dict, self.od.image(), true);
                self.controller.reset();
                self.reset_finish(now);
            }
        }
    }

    /// Reset application: the application part of the image from its
    /// defaults and the stored set, then the device's hook.
    fn reset_application_part(&mut self, now: At) {
        self.reset_part(Part::Application);
        self.reset_hook(now, NmtEvent::ResetApplication);
    }

    /// The device hears of the reset (its hook: `Application::on_nmt`),
    /// once for each part; a device error it reports changes no state while
    /// the node is Initialising.
    fn reset_hook(&mut self, now: At, event: NmtEvent) {
        self.with_app_resetting(now, |app, ctx| app.on_nmt(ctx, event));
    }

    /// The end of reset communication: LSS, SDO servers, acceptance list,
    /// NMT; the boot-up is due and the device hears of the reset.
    fn reset_finish(&mut self, now: At) {
        // Every service and every TPDO looks at the new configuration at the next process.
        self.stale = true;
        self.touched = ALL_TPDOS;
        self.refresh_lss();
        self.sdo.reset_all();
        self.configure_sdo();
        self.refresh_acceptance();
        // NMT is Initialising and no start pending since `begin_reset`: in
        // Initialising NMT takes no command and no state change, and only
        // the boot-up, never sent while resetting, sets `start_pending`.
        // An unconfigured node (0xFF) sends no boot-up and takes part in LSS only.
        self.boot_pending = self.hook.node_id != UNCONFIGURED && self.app.canopen();
        self.reset_hook(now, NmtEvent::ResetCommunication);
    }

    /// Reads the SDO server parameters 0x1200 + i sub 1 and 2 (reset
    /// communication, or after an SDO wrote one). A server whose COB-IDs
    /// changed drops its transfer. The default server exists even without
    /// 0x1200 (pre-defined connection set); a further one needs its object.
    pub(super) fn configure_sdo(&mut self) {
        let dict = self.od.dictionary();
        let image = self.od.image();
        // 128 servers at most: 0x1280 and up are SDO client parameters.
        for (i, slot) in self.sdo_cob_ids.iter_mut().enumerate().take(0x80) {
            // i < 0x80: 0x1200 + i stays below 0x1280.
            #[allow(clippy::arithmetic_side_effects)]
            let index = index::SDO_SERVER_PARAMETER + i as u16;
            // A server the dictionary lacks is not valid; the default one's pre-defined COB-IDs.
            #[allow(clippy::arithmetic_side_effects)]
            let (default_rx, default_tx) = if i == 0 {
                (0x600 + u32::from(self.hook.node_id), 0x580 + u32::from(self.hook.node_id))
            } else {
                (CobId::BIT31, CobId::BIT31)
            };
            let rx = CobId(dict.read_u32(image, index, 1).unwrap_or(default_rx));
            let tx = CobId(dict.read_u32(image, index, 2).unwrap_or(default_tx));
            let new = (rx.is_valid() && tx.is_valid()).then(|| (rx.can_id(), tx.can_id()));
            if *slot != new {
                self.sdo.reset(i);
                *slot = new;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Stage;

    fn walk(mut stage: Stage) -> std::vec::Vec<Stage> {
        let mut stages = std::vec![stage];
        while stage != Stage::Idle {
            stage = stage.next();
            stages.push(stage);
        }
        stages
    }

    #[test]
    fn the_stages_run_in_their_order() {
        use Stage::*;
        let communication = [Communication, Rpdos, Tpdos, Idle];
        assert_eq!(walk(FindThenCommunication)[1..], communication);
        assert_eq!(walk(FindOlderThenCommunication)[1..], communication);
        assert_eq!(walk(FindThenApplication)[1..2], [Application]);
        assert_eq!(walk(FindOlderThenApplication)[2..], communication);
        assert_eq!(walk(Idle), [Idle]);
    }
}
