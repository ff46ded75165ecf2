//! Building a node in place, as the images do (`firmware::image!`):
//! `Node::unpowered` with a zeroed RAM image (in a `const`, as the images'
//! `static`), then `Node::power_on` where the node lies. It must be the node
//! `Node::new` returns, stored parameters and all, and stay silent before
//! its power-on.

use canopen_core::frame::CanFrame;
use canopen_core::node::NoApplication;
use canopen_core::od::ObjectDictionary;
use canopen_core::services::nmt::NmtState;
use canopen_core::time::Instant;
use embedded_can::Frame;
use firmware::boards::qemu::ram_storage::RamStorage;
use firmware::boards::region_size;
use firmware::devices::ec5000::od;

type Storage = RamStorage<{ region_size(od::STORED_SIZE) }>;

const ID: u8 = 127;

fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

/// Runs the node at `t` (a store to its end, a stage per call) and returns what it sends.
fn step(node: &mut od::Node<NoApplication, Storage>, t: u64) -> Vec<(u16, Vec<u8>)> {
    node.process(ms(t));
    while node.storing() {
        node.process(ms(t));
    }
    std::iter::from_fn(|| node.transmit()).map(|f| (f.cob_id().expect("11-bit"), f.data().to_vec())).collect()
}

fn frame(cob_id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(cob_id, data).expect("valid frame")
}

/// Storage holding a saved heartbeat time of 1000 ms (0x1017, stored with 0x1010 sub 1).
fn stored_heartbeat() -> Storage {
    let mut node = od::Node::new(od::Ram::new(ID), NoApplication, Storage::default(), ID, ms(0));
    step(&mut node, 0);
    node.on_frame(ms(1), &frame(0x600 + u16::from(ID), &[0x2B, 0x17, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00]));
    node.on_frame(ms(2), &frame(0x600 + u16::from(ID), &[0x23, 0x10, 0x10, 0x01, b's', b'a', b'v', b'e']));
    assert_eq!(step(&mut node, 3), [(0x5FF, vec![0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]), (0x5FF, vec![0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0])]);
    node.storage_mut().clone()
}

#[test]
fn an_unpowered_node_is_silent_until_its_power_on() {
    let mut node = od::Node::unpowered(od::Ram::zeroed(), NoApplication, Storage::default());
    // NMT start and an SDO upload of 0x1000: ignored before power-on.
    node.on_frame(ms(0), &frame(0x000, &[0x01, ID]));
    node.on_frame(ms(0), &frame(0x600 + u16::from(ID), &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    assert_eq!(step(&mut node, 1), []);
    assert_eq!(node.state(), NmtState::Initialising);
    assert!(node.od().image().iter().all(|b| *b == 0), "the image stays as built");

    node.power_on(ID, ms(2));
    assert_eq!(step(&mut node, 2), [(0x700 + u16::from(ID), vec![0x00])], "boot-up");
    assert_eq!(node.state(), NmtState::PreOperational);
}

#[test]
fn power_on_in_place_gives_the_node_new_returns() {
    let storage = stored_heartbeat();
    let mut new = od::Node::new(od::Ram::new(ID), NoApplication, storage.clone(), ID, ms(0));
    let mut in_place = od::Node::unpowered(od::Ram::zeroed(), NoApplication, storage);
    in_place.power_on(ID, ms(0));
    assert_ne!(new.od().image(), od::Ram::new(ID).image(), "the stored 0x1017 is loaded");
    assert_eq!(in_place.od().image(), new.od().image(), "same dictionary");
    assert_eq!((in_place.node_id(), in_place.state()), (new.node_id(), new.state()));
    // Boot-up, then the stored heartbeat of 1000 ms (pre-operational: 0x7F).
    for t in [0, 999, 1000, 2000] {
        assert_eq!(step(&mut in_place, t), step(&mut new, t), "at {t} ms");
    }
    assert_eq!(step(&mut in_place, 3000), [(0x700 + u16::from(ID), vec![0x7F])]);
}

/// What `firmware::image!` puts in its `static`: a node built at compile time.
const UNPOWERED: od::Node<NoApplication, Storage> = od::Node::unpowered(od::Ram::zeroed(), NoApplication, Storage::new());

#[test]
fn a_node_built_in_a_const_powers_on_as_node_new_does() {
    let storage = stored_heartbeat();
    let mut new = od::Node::new(od::Ram::new(ID), NoApplication, storage.clone(), ID, ms(0));
    let mut from_const = UNPOWERED;
    *from_const.storage_mut() = storage;
    assert_eq!(step(&mut from_const, 0), [], "silent before power-on");
    from_const.power_on(ID, ms(0));
    assert_eq!(from_const.od().image(), new.od().image());
    assert_eq!((from_const.node_id(), from_const.state()), (new.node_id(), new.state()));
    assert_eq!(from_const.acceptance(), new.acceptance());
    for t in [0, 999, 1000, 2000, 3000] {
        assert_eq!(step(&mut from_const, t), step(&mut new, t), "at {t} ms");
    }
    // Operational: the TPDOs send their first values, as on a node from `Node::new`.
    let start = frame(0x000, &[0x01, ID]);
    from_const.on_frame(ms(3001), &start);
    new.on_frame(ms(3001), &start);
    let sent = step(&mut new, 3002);
    assert!(sent.iter().any(|(id, _)| (0x181..0x580).contains(id)), "ec5000 sends TPDOs: {sent:?}");
    assert_eq!(step(&mut from_const, 3002), sent);
}

#[test]
fn power_on_overwrites_every_byte_of_the_image() {
    // What power-on does to the image before it loads stored parameters:
    // from any contents it gives the defaults, so `Node::unpowered` may take
    // `Ram::zeroed`.
    macro_rules! check {
        ($($device:ident),*) => {$(
            let mut ram = firmware::devices::$device::od::Ram::zeroed();
            ram.image_mut().fill(0xA5);
            ram.reset_application(ID);
            ram.reset_communication(ID);
            assert_eq!(ram.image(), firmware::devices::$device::od::Ram::new(ID).image(), stringify!($device));
        )*};
    }
    check!(ec5000, unitek_ds, sendix, bmaxx4400, agile);
}
