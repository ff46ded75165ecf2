//! The STM32 board's report of a reset caused by a failure
//! (`boards::stm32f103::reset_cause`), as the node sends and records it:
//! after boot-up an EMCY 0x6100 (panic, HardFault, watchdog) or 0x5000
//! (crystal) with the cause and RCC_CSR's flags in the manufacturer bytes,
//! readable afterwards by SDO in 0x1003 sub 1; cleared a second later
//! ("error reset"), the history entry stays.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::wire::emcy::EmcyCode;
use common::{Bench, ms};
use embedded_can::Frame as _;
use firmware::boards::stm32f103::reset_cause::{ResetCause, classify};
use firmware::devices::ec5000;
use firmware::devices::ec5000::od;
use hal_host::storage::MemStorage;

const ID: u8 = 5;
type Ec5000 = Bench<od::Ram, NoApplication, MemStorage, { od::RPDO_COUNT }, { od::TPDO_COUNT }, { od::HB_CONSUMER_COUNT }>;

#[test]
fn a_panic_reset_is_an_emcy_after_boot_up_and_readable_in_0x1003() {
    let mut b: Ec5000 = Bench::new(od::Ram::new(ID), NoApplication, MemStorage::new(2048), ID);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])], "boot-up first");
    // RCC_CSR after the firmware's SYSRESETREQ: SFTRSTF | PINRSTF; the panic's reason left in RAM.
    let csr = (1 << 28) | (1 << 26);
    let cause = classify(csr, Some(ResetCause::Panic as u32));
    let (code, info) = cause.emcy((csr >> 24) as u8, EmcyCode::INTERNAL_SOFTWARE).expect("a panic is reported");
    b.node.raise_error(code, info);
    assert_eq!(
        b.at(ms(250)),
        [(0x85, vec![0x00, 0x61, 0x21, 0x02, 0x14, 0x00, 0x00, 0x00])],
        "EMCY 0x6100; the core sets error register bits 0 and 5 for 0x6xxx"
    );
    assert_eq!(b.sdo_upload(ID, 0x1003, 0), Ok(vec![1]));
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(0x1402_6100u32.to_le_bytes().to_vec()), "cause 2 (panic), flags 0x14");
    b.node.clear_error(code);
    assert_eq!(b.at(ms(1250)), [(0x85, vec![0; 8])], "error reset");
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(0x1402_6100u32.to_le_bytes().to_vec()), "the history keeps it");
}

#[test]
fn a_cause_raised_before_the_boot_up_leaves_right_after_it() {
    // The STM32 board raises the cause on the node it has just built, before
    // the CANopen task runs it: the EMCY waits for the boot-up.
    let mut b: Ec5000 = Bench::new(od::Ram::new(ID), NoApplication, MemStorage::new(2048), ID);
    let csr = (1 << 29) | (1 << 26); // IWDGRSTF | PINRSTF
    let (code, info) = classify(csr, None).emcy((csr >> 24) as u8, EmcyCode::INTERNAL_SOFTWARE).expect("a watchdog reset is reported");
    b.node.raise_error(code, info);
    // By priority the EMCY (0x85) would pass the boot-up (0x705) if both
    // were queued in one call: the EMCY waits for the next, due at once.
    assert_eq!(b.node.process(ms(0)), Some(ms(0)), "the EMCY is due at once");
    let boot_up = b.node.transmit().map(|f| (f.cob_id(), f.data().to_vec()));
    assert_eq!(boot_up, Some((Some(0x705), vec![0x00])));
    assert!(b.node.transmit().is_none(), "the EMCY waits for the next call");
    assert_eq!(b.at(ms(0)), [(0x85, vec![0x00, 0x61, 0x21, 0x01, 0x24, 0x00, 0x00, 0x00])]);
}

#[test]
fn a_crystal_that_did_not_start_is_a_hardware_emcy() {
    let mut b: Ec5000 = Bench::new(od::Ram::new(ID), NoApplication, MemStorage::new(2048), ID);
    b.at(ms(0));
    let csr = (1 << 29) | (1 << 26); // IWDGRSTF | PINRSTF
    let (code, info) =
        classify(csr, Some(ResetCause::Crystal as u32)).emcy((csr >> 24) as u8, EmcyCode::INTERNAL_SOFTWARE).expect("reported");
    b.node.raise_error(code, info);
    assert_eq!(b.at(ms(250)), [(0x85, vec![0x00, 0x50, 0x01, 0x04, 0x24, 0x00, 0x00, 0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(0x2404_5000u32.to_le_bytes().to_vec()));
}

#[test]
fn the_ec5000_image_reports_a_watchdog_restart_as_0x6010() {
    // M §9.1 L1680 "Restart (powerfail, watchdog)" (docs/devices/ec5000.md D53):
    // the image gives the board this code in place of 0x6100.
    let mut b: Bench<od::Ram, ec5000::App, MemStorage, 4, 4, 1> = Bench::new(od::Ram::new(ID), ec5000::App::NEW, MemStorage::new(4096), ID);
    assert_eq!(b.at(ms(0)), [(0x705, vec![0x00])]);
    let csr = (1 << 29) | (1 << 26); // IWDGRSTF | PINRSTF
    let (code, info) = classify(csr, None).emcy((csr >> 24) as u8, ec5000::RESTART).expect("reported");
    b.node.raise_error(code, info);
    assert_eq!(b.at(ms(250)), [(0x85, vec![0x10, 0x60, 0x21, 0x01, 0x24, 0x00, 0x00, 0x00])]);
    assert_eq!(b.sdo_upload(ID, 0x1003, 1), Ok(0x2401_6010u32.to_le_bytes().to_vec()));
}
