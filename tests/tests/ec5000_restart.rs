//! 0x1F51 sub 1 "Restart" on the EC5000 (D51): writing 1 answers the SDO,
//! then the drive restarts as after NMT reset node: boot-up, Pre-operational,
//! the PDS in Switch on disabled, unsaved parameters back to their defaults.

mod common;

use common::ec5000::*;
use common::{abort, ms};

#[test]
fn writing_1_restarts_the_drive() {
    let mut b = enabled();
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x16]), "Operation enabled");
    b.sdo_download(ID, 0x4231, 1, &100i16.to_le_bytes()).expect("a parameter, not stored");
    // The answer, then the boot-up, in the same process.
    let out = b.rx(ms(800), 0x605, &[0x2F, 0x51, 0x1F, 0x01, 0x01, 0, 0, 0]);
    assert_eq!(out, [(0x585, vec![0x60, 0x51, 0x1F, 0x01, 0, 0, 0, 0]), (0x705, vec![0x00])]);
    // Pre-operational: no PDOs; the drive and the parameters as at power-on.
    assert_eq!(b.run_until(ms(1000)), []);
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x50, 0x02]), "Switch on disabled");
    assert_eq!(b.sdo_upload(ID, 0x4231, 1), Ok(vec![95, 0]));
    assert_eq!(b.sdo_upload(ID, 0x1F51, 1), Ok(vec![0]));
}

#[test]
fn other_values_are_refused() {
    let mut b = enabled();
    for v in [0u8, 2, 255] {
        assert_eq!(b.sdo_write(ID, 0x1F51, 1, &[v]), abort(0x1F51, 1, 0x0609_0030), "{v}");
    }
    assert_eq!(b.sdo_upload(ID, 0x6041, 0), Ok(vec![0x37, 0x16]), "still Operation enabled");
}
