//! The EC5000's RPDOs as its fixed mappings have them: the objects each
//! RPDO writes and their image bytes, kept at its first frame after reset
//! communication, so that an RPDO reaches the profile without asking the
//! node for its mapping object by object (the CiA 402 row of `cargo xtask icount`).
//!
//! The manual fixes the RPDO mappings (`eds/ec5000.eds`: 0x1600-0x1603 sub 0
//! const, the entries read-only). Only an RPDO whose mapping count (sub 0)
//! cannot be written is taken as fixed; any other RPDO, or one with more
//! objects than kept here, is read from the node's mapping object by object
//! ([`Ctx::rpdo_object`]), as on any device.

use canopen_core::node::{Application, Ctx, ImageSlot, rpdo_object_written};
use canopen_core::od::EntryRef;
use canopen_core::services::pdo::map::MAX_ENTRIES;

/// The RPDOs looked at (0x1600-0x1603).
const RPDOS: usize = 4;
/// Objects kept per RPDO: the controlword and a set-point (RPDO2, RPDO3);
/// RPDO1's three objects are asked for at every frame.
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
        [Fixed { objects: [Object { at: EntryRef::NONE, slot: ImageSlot::NONE, len: 0 }; OBJECTS], count: 0, plan: Plan::Unknown }; RPDOS],
    );

    fn plan(&self, n: u8) -> Plan {
        self.0.get(usize::from(n)).map_or(Plan::Asked, |r| r.plan)
    }

    /// Object `i` of fixed RPDO `n`: its entry, the value the image holds
    /// for it (as [`Ctx::rpdo_object`] gives it) and its mapped length.
    fn object(&self, ctx: &Ctx<'_>, n: u8, i: usize) -> Option<(EntryRef, u32, u8)> {
        let rpdo = self.0.get(usize::from(n))?;
        let object = rpdo.objects.get(..usize::from(rpdo.count))?.get(i)?;
        Some((object.at, ctx.slot_value(object.slot), object.len))
    }

    /// Keeps the next object of RPDO `n` (a dummy entry maps nothing: not kept).
    fn keep(&mut self, ctx: &Ctx<'_>, n: u8, at: EntryRef, len: u8) {
        let Some(rpdo) = self.0.get_mut(usize::from(n)) else { return };
        if !at.is_some() {
            return;
        }
        match rpdo.objects.get_mut(usize::from(rpdo.count)) {
            Some(object) => {
                *object = Object { at, slot: ctx.image_slot(at), len };
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
        rpdo.count = 0;
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

/// RPDO `n` wrote its objects: for each, in mapping order, as kept at its
/// first frame if its mapping is fixed (else as the node has it,
/// [`Ctx::rpdo_object`]), offered to the device by [`rpdo_object_written`]
/// (as the default [`Application::rpdo_written`] does).
pub(super) fn written<A: Application>(app: &mut A, rpdos: impl Fn(&mut A) -> &mut FixedRpdos, ctx: &mut Ctx<'_>, n: u8) {
    let mut plan = rpdos(app).plan(n);
    if plan == Plan::Unknown {
        plan = rpdos(app).first(ctx, n);
    }
    for i in 0..MAX_ENTRIES {
        let object = if plan == Plan::Fixed { rpdos(app).object(ctx, n, i) } else { ctx.rpdo_object(n, i) };
        let Some((at, value, len)) = object else { break };
        if plan == Plan::Unknown {
            rpdos(app).keep(ctx, n, at, len);
        }
        rpdo_object_written(app, ctx, n, at, value, len);
    }
    if plan == Plan::Unknown {
        rpdos(app).kept(n);
    }
}
