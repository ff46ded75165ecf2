//! The EC5000's RPDOs as its fixed mappings have them: the objects each
//! RPDO writes and their image bytes, kept at its first frame after reset
//! communication, so that an RPDO reaches the profile without asking the
//! node for its mapping object by object (the CiA 402 row of `cargo xtask icount`).
//!
//! The manual fixes the RPDO mappings (`eds/ec5000.eds`: 0x1600-0x1603 sub 0
//! const, the entries read-only), each with the controlword first: the
//! profile takes it straight from its image bytes, the objects after it
//! (a set-point, the mode) go to the device one by one. Only an RPDO whose
//! mapping count (sub 0) cannot be written is taken as fixed; any other
//! RPDO, or one with more objects than kept here, is read from the node's
//! mapping object by object ([`Ctx::rpdo_object`]), as on any device.

use canopen_core::node::{Ctx, ImageSlot, rpdo_object_written};
use canopen_core::od::EntryRef;
use canopen_core::services::pdo::map::MAX_ENTRIES;

use super::App;

/// The RPDOs looked at (0x1600-0x1602): RPDO4's mapping (0x1603) can be
/// written, so it is asked for at every frame anyway. (Three, not four:
/// the node's fields after the device stay within the short offsets of
/// their loads, 80 B of the drive's flash.)
const RPDOS: usize = 3;
/// Objects kept per RPDO after its controlword: a set-point (RPDO2,
/// RPDO3), the mode and the profile velocity (RPDO1).
const OBJECTS: usize = 2;
/// The RPDO mapping records' first index.
const RPDO_MAPPING: u16 = 0x1600;

/// One mapped object: its entry, its image bytes (the value the RPDO wrote)
/// and its mapped length.
#[derive(Clone, Copy, Debug)]
struct Object {
    at: EntryRef,
    slot: ImageSlot,
    len: u8,
}

/// What is known of RPDO n's mapping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Plan {
    /// Nothing yet (first, so that [`FixedRpdos::NONE`] is all zero bits):
    /// the next RPDO finds out.
    Unknown,
    /// Fixed: its objects are kept.
    Fixed,
    /// It may change, or has more objects than kept: asked for at every RPDO.
    Asked,
}

/// RPDO n's objects, when its mapping is fixed.
#[derive(Clone, Copy, Debug)]
struct Fixed {
    /// The controlword's image bytes if it is the first object
    /// ([`ImageSlot::NONE`] if not): the profile takes it without a compare.
    controlword: ImageSlot,
    /// The objects after it (all of them without it), in mapping order.
    objects: [Object; OBJECTS],
    count: u8,
    plan: Plan,
}

/// The fixed RPDOs: all zero bits, nothing known, until each RPDO's first
/// frame after reset communication.
#[derive(Clone, Copy, Debug)]
pub(super) struct FixedRpdos([Fixed; RPDOS]);

impl FixedRpdos {
    /// Nothing known yet (and after reset communication, which configures the RPDOs again).
    pub(super) const NONE: FixedRpdos = FixedRpdos(
        [Fixed {
            controlword: ImageSlot::NONE,
            objects: [Object { at: EntryRef::NONE, slot: ImageSlot::NONE, len: 0 }; OBJECTS],
            count: 0,
            plan: Plan::Unknown,
        }; RPDOS],
    );

    /// Keeps the next object of RPDO `n`: the first as the controlword if
    /// `object.slot` holds its image bytes (a dummy entry maps nothing: not kept).
    fn keep(&mut self, ctx: &Ctx<'_>, n: u8, object: Object) {
        let Some(rpdo) = self.0.get_mut(usize::from(n)) else { return };
        if object.slot != ImageSlot::NONE {
            rpdo.controlword = object.slot;
            return;
        }
        if !object.at.is_some() {
            return;
        }
        match rpdo.objects.get_mut(usize::from(rpdo.count)) {
            Some(kept) => {
                *kept = Object { slot: ctx.image_slot(object.at), ..object };
                rpdo.count = rpdo.count.saturating_add(1);
            }
            None => rpdo.plan = Plan::Asked,
        }
    }

    /// The first frame of RPDO `n`: its objects are kept as it goes if its
    /// mapping is fixed, else it is asked for at every frame.
    fn first(&mut self, ctx: &Ctx<'_>, n: u8) -> Plan {
        // The mapping in use changes only when sub 0 (the count) is written
        // (CiA 301 §7.5.2.36; the EC5000 does not take entries written while
        // the RPDO is valid, `pdo_rewrite_while_valid`).
        let index = RPDO_MAPPING.wrapping_add(u16::from(n));
        let Some(rpdo) = self.0.get_mut(usize::from(n)) else { return Plan::Asked };
        (rpdo.controlword, rpdo.count) = (ImageSlot::NONE, 0);
        if ctx.dictionary().find(index, 0).is_ok_and(|e| e.writable()) {
            rpdo.plan = Plan::Asked;
        }
        rpdo.plan
    }

    /// RPDO `n`'s objects are all kept (unless there were too many).
    fn kept(&mut self, n: u8) {
        if let Some(rpdo) = self.0.get_mut(usize::from(n))
            && rpdo.plan == Plan::Unknown
        {
            rpdo.plan = Plan::Fixed;
        }
    }
}

/// RPDO `n` wrote its objects: if its mapping is fixed, the controlword
/// to the profile and the objects after it, in mapping order, as kept at
/// its first frame (else each as the node has it, [`Ctx::rpdo_object`]);
/// each object offered to the device by [`rpdo_object_written`] (as the
/// default [`canopen_core::node::Application::rpdo_written`] does).
pub(super) fn written(app: &mut App, ctx: &mut Ctx<'_>, n: u8) {
    let mut plan = Plan::Asked;
    if let Some(&Fixed { plan: rpdo, controlword, count, .. }) = app.rpdos.0.get(usize::from(n)) {
        if rpdo == Plan::Fixed {
            if controlword != ImageSlot::NONE {
                app.drive.rpdo_controlword(ctx, ctx.slot_u16(controlword));
            }
            for i in 0..usize::from(count) {
                let Some(&Object { at, slot, len }) = app.rpdos.0.get(usize::from(n)).and_then(|r| r.objects.get(i)) else { break };
                rpdo_object_written(app, ctx, n, at, ctx.slot_value(slot), len);
            }
            return;
        }
        plan = if rpdo == Plan::Unknown { app.rpdos.first(ctx, n) } else { rpdo };
    }
    for i in 0..MAX_ENTRIES {
        let Some((at, value, len)) = ctx.rpdo_object(n, i) else { break };
        if plan == Plan::Unknown {
            // A controlword without image bytes (none can be mapped) is an object as any other.
            let slot = if i == 0 && app.drive.is_controlword(at) { ctx.image_slot(at) } else { ImageSlot::NONE };
            app.rpdos.keep(ctx, n, Object { at, slot, len });
        }
        rpdo_object_written(app, ctx, n, at, value, len);
    }
    if plan == Plan::Unknown {
        app.rpdos.kept(n);
    }
}
