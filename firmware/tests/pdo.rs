//! PDOs and SYNC on the real device dictionaries: the default mappings of
//! the manuals resolve, the drive's RPDO1/TPDO1 move the controlword and
//! statusword with the EDS's inhibit time and event timer, the PDO4
//! mappings are dynamic, and the encoder's TPDOs refuse RTRs.

use canopen_core::abort::AbortCode;
use canopen_core::od::{Dictionary, ObjectDictionary};
use canopen_core::services::pdo::{PdoEvent, PdoTx, Pdos};
use canopen_core::services::sync::{SyncEvent, SyncService};
use canopen_core::time::{At, Far};
use canopen_core::wire::emcy::EmcyCode;
use canopen_firmware::devices::{self, ec5000, sendix};

#[derive(Default)]
struct Bus {
    frames: Vec<(u16, Vec<u8>)>,
    events: Vec<PdoEvent>,
}

impl PdoTx for Bus {
    fn send(&mut self, cob_id: u16, data: &[u8]) -> bool {
        self.frames.push((cob_id, data.to_vec()));
        true
    }

    fn event(&mut self, event: PdoEvent) {
        self.events.push(event);
    }
}

impl Bus {
    fn take(&mut self) -> Vec<(u16, Vec<u8>)> {
        std::mem::take(&mut self.frames)
    }
}

fn ms(t: u32) -> At {
    t * 1000
}

fn image(d: &Dictionary, node_id: u8) -> Vec<u8> {
    let mut img = vec![0u8; d.defaults.len];
    d.reset_application(&mut img, node_id);
    d.reset_communication(&mut img, node_id);
    img
}

#[test]
fn every_device_configures_its_default_pdos_and_sync() {
    for dev in &devices::ALL {
        let img = image(dev.dictionary, 1);
        let mut pdos: Pdos<8, 8> = Pdos::default();
        assert_eq!(pdos.configure(dev.dictionary, &img), Ok(()), "{}", dev.name);
        let mut sync = SyncService::default();
        sync.configure(dev.dictionary, &img);
        assert!(!sync.is_producing(), "{}", dev.name);
    }
}

#[test]
fn ec5000_rpdo1_writes_controlword_mode_and_profile_velocity() {
    let mut ram = ec5000::od::Ram::new(1);
    let d = ram.dictionary();
    let mut pdos: Pdos<{ ec5000::od::RPDO_COUNT }, { ec5000::od::TPDO_COUNT }> = Pdos::default();
    assert_eq!(pdos.configure(d, ram.image()), Ok(()));
    pdos.enter_operational(ms(0));
    let mut bus = Bus::default();
    // 0x1600: 0x6040 (16), 0x6060 (8), 0x6081 (32).
    assert!(pdos.on_frame(ms(1), 0x201, &[0x0F, 0x00, 0x03, 0x10, 0x27, 0x00, 0x00], ram.image_mut(), &mut bus));
    assert_eq!(bus.events, [PdoEvent::Received(0)]);
    assert_eq!((ram.controlword(), ram.modes_of_operation()), (0x000F, 3));
    assert_eq!(d.read(ram.image(), ec5000::od::index::PROFILE_VELOCITY, 0), Ok(&10_000u32.to_le_bytes()[..]));
    // A frame of 2 bytes is too short for 7 mapped bytes: EMCY 0x8210, nothing written.
    assert!(pdos.on_frame(ms(2), 0x201, &[0x06, 0x00], ram.image_mut(), &mut bus));
    assert_eq!(bus.events[1..], [PdoEvent::Error { rpdo: 0, code: EmcyCode(0x8210) }]);
    assert_eq!(ram.controlword(), 0x000F);
}

#[test]
fn ec5000_tpdo1_sends_the_statusword_within_its_inhibit_time_and_event_timer() {
    let mut ram = ec5000::od::Ram::new(1);
    let d = ram.dictionary();
    let mut pdos: Pdos<4, 4> = Pdos::default();
    assert_eq!(pdos.configure(d, ram.image()), Ok(()));
    ram.set_statusword(0x0250);
    ram.set_modes_of_operation_display(1);
    pdos.enter_operational(ms(0));
    let mut bus = Bus::default();
    // TPDO1 and TPDO2 are event-driven (inhibit 100 ms, event timer 2000 ms); TPDO3 is on SYNC; TPDO4 maps nothing.
    assert_eq!(pdos.poll(ms(0), ram.image(), &mut bus), Some(ms(2000)));
    assert_eq!(bus.take(), [(0x181, vec![0x50, 0x02, 1, 0, 0, 0, 0, 0]), (0x281, vec![0x50, 0x02, 0, 0, 0, 0])]);
    ram.set_statusword(0x0231);
    assert_eq!(pdos.poll(ms(10), ram.image(), &mut bus), Some(ms(100)), "inhibit time 1000 × 100 µs");
    assert!(bus.take().is_empty());
    assert_eq!(pdos.poll(ms(100), ram.image(), &mut bus), Some(ms(2100)));
    assert_eq!(bus.take(), [(0x181, vec![0x31, 0x02, 1, 0, 0, 0, 0, 0]), (0x281, vec![0x31, 0x02, 0, 0, 0, 0])]);
    assert_eq!(pdos.poll(ms(2100), ram.image(), &mut bus), Some(ms(4100)));
    assert_eq!(bus.take().len(), 2, "the event timer");
    // TPDO3 (type 1): statusword + 0x606C on every SYNC.
    let mut sync = SyncService::default();
    sync.configure(d, ram.image());
    let event: SyncEvent = sync.on_frame(ms(2200), &[]).unwrap();
    pdos.on_sync(&event, ram.image_mut(), &mut bus);
    assert_eq!(bus.take(), [(0x381, vec![0x31, 0x02, 0, 0, 0, 0])]);
}

#[test]
fn ec5000_pdo4_mappings_are_dynamic() {
    let mut ram = ec5000::od::Ram::new(1);
    let d = ram.dictionary();
    let mut pdos: Pdos<4, 4> = Pdos::default();
    assert_eq!(pdos.configure(d, ram.image()), Ok(()));
    let mut sdo = |ram: &mut ec5000::od::Ram, index: u16, sub: u8, data: &[u8]| {
        pdos.write_object(index, sub, data, d, ram.image_mut()).expect("a PDO parameter")
    };
    // TPDO4, by the CiA 301 procedure: its COB-ID is writable.
    assert_eq!(sdo(&mut ram, 0x1803, 1, &0x8000_0481u32.to_le_bytes()), Ok(()));
    assert_eq!(sdo(&mut ram, 0x1A03, 1, &0x6040_0010u32.to_le_bytes()), Err(AbortCode::NotMappable), "rww");
    assert_eq!(sdo(&mut ram, 0x1A03, 1, &0x6041_0010u32.to_le_bytes()), Ok(()));
    assert_eq!(sdo(&mut ram, 0x1A03, 2, &0x6061_0008u32.to_le_bytes()), Ok(()));
    assert_eq!(sdo(&mut ram, 0x1A03, 0, &[2]), Ok(()));
    assert_eq!(sdo(&mut ram, 0x1803, 1, &0x0000_0481u32.to_le_bytes()), Ok(()));
    // RPDO4: the COB-ID is read-only, so sub 0 = 0 alone opens the mapping (docs/devices/ec5000.md, 13).
    assert_eq!(sdo(&mut ram, 0x1403, 1, &0x8000_0501u32.to_le_bytes()), Err(AbortCode::ReadOnly));
    assert_eq!(sdo(&mut ram, 0x1603, 1, &0x6041_0010u32.to_le_bytes()), Err(AbortCode::NotMappable), "ro");
    assert_eq!(sdo(&mut ram, 0x1603, 1, &0x6040_0010u32.to_le_bytes()), Ok(()));
    // The EDS's high limit of sub 0 answers first, as it does in the node.
    assert_eq!(sdo(&mut ram, 0x1603, 0, &[9]), Err(AbortCode::ValueTooHigh));
    assert_eq!(sdo(&mut ram, 0x1603, 0, &[1]), Ok(()));
    // The static mappings of PDO1..3 are read-only.
    assert_eq!(sdo(&mut ram, 0x1A00, 0, &[0]), Err(AbortCode::ReadOnly));

    pdos.enter_operational(ms(0));
    let mut bus = Bus::default();
    assert!(pdos.on_frame(ms(1), 0x501, &[0x80, 0x00], ram.image_mut(), &mut bus));
    assert_eq!(ram.controlword(), 0x0080);
    ram.set_statusword(0x0637);
    ram.set_modes_of_operation_display(1);
    pdos.poll(ms(2), ram.image(), &mut bus);
    let frames = bus.take();
    assert!(frames.contains(&(0x481, vec![0x37, 0x06, 0x01])), "{frames:02X?}");
}

#[test]
fn sendix_tpdos_refuse_rtr_and_follow_the_position() {
    let mut ram = sendix::od::Ram::new(0x3F);
    let d = ram.dictionary();
    let mut pdos: Pdos<0, { sendix::od::TPDO_COUNT }> = Pdos::default();
    assert_eq!(pdos.configure(d, ram.image()), Ok(()));
    pdos.enter_operational(ms(0));
    let mut bus = Bus::default();
    ram.set_position_value(0x0001_E240);
    assert_eq!(pdos.poll(ms(0), ram.image(), &mut bus), None);
    let frames = bus.take();
    assert!(frames.contains(&(0x1BF, vec![0x40, 0xE2, 0x01, 0x00])), "{frames:02X?}");
    // COB-ID bit 30: no RTR (manual L1655).
    assert!(!pdos.on_rtr(ms(1), 0x1BF, ram.image(), &mut bus));
    assert!(bus.take().is_empty());
    // TT 255 with no event timer: sent on each change of the position (§5.2.3).
    ram.set_position_value(0x0001_E241);
    pdos.poll(ms(2), ram.image(), &mut bus);
    assert_eq!(bus.take(), [(0x1BF, vec![0x41, 0xE2, 0x01, 0x00])]);
    // TPDO2 goes out on every SYNC.
    pdos.on_sync(&SyncEvent { at: ms(3), counter: None, window_end: Far::NEVER }, ram.image_mut(), &mut bus);
    assert_eq!(bus.take(), [(0x2BF, vec![0x41, 0xE2, 0x01, 0x00])]);
}
