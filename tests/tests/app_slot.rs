//! The application slot's way into the node, as the images run it: a
//! value written through the device's generated accessor (reached from
//! `&mut dyn CanNode` with `can_node::od_mut`) goes out in the TPDO that
//! maps it, and `trigger_tpdo` sends an event-driven TPDO on demand.

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::time::Instant;
use embedded_can::Frame;
use firmware::boards::qemu::ram_storage::RamStorage;
use firmware::boards::region_size;
use firmware::can_node::{CanNode, od_mut};
use firmware::devices::{ec5000, sendix};

type Storage = RamStorage<{ region_size(sendix::od::RAM_SIZE) }>;

const ID: u8 = 0x3F;
/// TPDO1 of the Sendix: 0x180 + node-id, maps 0x6004 Position value, event-driven (type 255).
const TPDO1: u16 = 0x1BF;

fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

/// Runs the node at `t` and returns what it sends.
fn step(node: &mut dyn CanNode, t: u64) -> Vec<(u16, Vec<u8>)> {
    node.process(ms(t));
    std::iter::from_fn(|| node.transmit()).map(|f| (f.cob_id().expect("11-bit"), f.data().to_vec())).collect()
}

#[test]
fn a_value_the_application_writes_goes_out_in_its_tpdo() {
    let mut sendix = sendix::od::Node::new(sendix::od::Ram::new(ID), NoApplication, Storage::default(), ID, ms(0));
    let node: &mut dyn CanNode = &mut sendix;
    assert_eq!(step(node, 0), [(0x73F, vec![0x00])]);
    node.on_frame(ms(1), &CanFrame::standard(0x000, &[0x01, ID]).expect("NMT start"));
    // Event-driven TPDOs go out on entering Operational: TPDO1 and TPDO3 (0x380 + node-id, speed value 0x6030 sub 1).
    assert_eq!(step(node, 1), [(TPDO1, vec![0, 0, 0, 0]), (0x3BF, vec![0, 0, 0, 0])]);

    od_mut::<sendix::od::Ram>(node).expect("the node runs the Sendix dictionary").set_position_value(0x0001_E240);
    assert_eq!(step(node, 2), [(TPDO1, vec![0x40, 0xE2, 0x01, 0x00])], "change of state");
    assert_eq!(step(node, 3), [], "nothing changed");

    assert!(node.trigger_tpdo(0));
    assert_eq!(step(node, 4), [(TPDO1, vec![0x40, 0xE2, 0x01, 0x00])], "an application event sends it unchanged");
    assert_eq!(step(node, 5), []);
}

#[test]
fn another_dictionary_type_is_refused() {
    let mut sendix = sendix::od::Node::new(sendix::od::Ram::new(ID), NoApplication, Storage::default(), ID, ms(0));
    let node: &mut dyn CanNode = &mut sendix;
    assert!(od_mut::<ec5000::od::Ram>(node).is_none());
    assert!(!node.trigger_tpdo(7), "no TPDO8");
}
