//! Who controls the inverter, and how transition 5 stops it (§10, §10.2,
//! §10.3.2, M-L3021-3054, M-L3180-3187, M-L3226-3254; D56 and D57 in
//! docs/devices/agile.md). Parameters 412 and 392 have four data sets: the
//! active one counts, which p.414 selects (1-4); its 0 and 5 leave the
//! choice to the contacts, which the simulated inverter lacks: data set 1.

use canopen_core::node::Ctx;

/// p.392 "Übergang 5 der State machine" (0x2188): 0 coast, 1 DC brake, 2 ramp.
pub(super) const TRANSITION_5: u16 = 0x2188;
/// p.412 "Local/Remote" (0x219C): 0 contacts, 1 state machine, 2 remote contacts.
pub(super) const LOCAL_REMOTE: u16 = 0x219C;
/// p.414 "Datensatzanwahl" (0x219E).
pub(super) const DATA_SET_SELECTION: u16 = 0x219E;
/// p.249 "aktiver Datensatz" (0x20F9).
const ACTIVE_DATA_SET: u16 = 0x20F9;

/// The active data set (p.249 shows it).
pub(super) fn active_set(ctx: &mut Ctx<'_>) -> u8 {
    let set = match ctx.read_u32(DATA_SET_SELECTION, 0) {
        Some(set @ 1..=4) => set as u8,
        _ => 1,
    };
    let _ = ctx.set_value(ACTIVE_DATA_SET, 0, &u16::from(set).to_le_bytes());
    set
}

/// p.412 of data set `set` selects contacts (0) or remote contacts (2): the controlword does
/// not drive the state machine ("anwendbar, wenn … 412 auf 1", M-L3109) and
/// statusword bit 9 is clear. The keypad's settings (3-44, factory 44)
/// concern a keypad the simulated inverter lacks: the bus controls it (D46).
pub(super) fn local(ctx: &Ctx<'_>, set: u8) -> bool {
    matches!(ctx.read_u32(LOCAL_REMOTE, set), Some(0 | 2))
}

/// p.392 is 0 "freier Auslauf": transition 5 switches off at once and the
/// motor coasts (2 "Rampe", the factory value, is the profile's slow-down
/// ramp; 1 "Gleichstrombremse" cannot be set, [`refused`]).
pub(super) fn transition_5_coasts(ctx: &mut Ctx<'_>) -> bool {
    let set = active_set(ctx);
    ctx.read_u32(TRANSITION_5, set) == Some(0)
}

/// p.392 = 1 "Gleichstrombremse" works with V/f control only; "bei einer
/// Konfiguration, welche die Betriebsart Gleichstrombremse nicht unterstützt
/// (z. B. feldorientierte Regelung), kann der Wert 1 nicht eingestellt
/// werden" (M-L3240): the axis model is a speed-controlled drive (0x06090030).
pub(super) fn refused(index: u16, data: &[u8]) -> bool {
    index == TRANSITION_5 && data == [1, 0]
}
