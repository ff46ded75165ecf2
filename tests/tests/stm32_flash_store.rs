//! Stored parameters on STM32F1 flash, for all five devices: the firmware's
//! flash adapter (`boards::stm32f103::flash_storage`, what the STM32 images
//! run) on hal-host's model of the part (half-word reads, programs and page
//! erases; a half-word programmed only when erased; 1 KiB pages as on the
//! F103C8, or 2 KiB as on high-density parts). Every stored entry of each
//! dictionary is changed, saved, the power cycled, and read back; partial
//! saves (0x1010 sub 2–4) and LSS "store configuration" over an existing
//! set; and a power cut at every erase and program of a save leaves the old
//! set or the new one, never a mix. Each check also requires that the
//! store never broke a rule of the part.

mod common;

use canopen_core::node::NoApplication;
use canopen_core::od::{Attr, Dictionary, Entry, ObjectDictionary};
use canopen_core::services::store::{self, Part, Scope};
use common::{Bench, ms};
use firmware::boards::region_size;
use hal_host::storage::{Layout, MemStorage};
use od_gen::codegen::NEVER_STORED;

const ID: u8 = 5;

/// Whether the store keeps `e` (a writable value in RAM).
fn stored(e: &Entry) -> bool {
    e.attr.contains(Attr::WRITE) && !e.in_rom() && e.len > 0 && !NEVER_STORED.contains(&{ e.index })
}

fn scope_of(index: u16) -> Scope {
    match index {
        0x1000..=0x1FFF => Scope::Communication,
        0x2000..=0x5FFF => Scope::Manufacturer,
        _ => Scope::Application,
    }
}

/// `image` with every stored entry of `scope` (or all) changed by `salt`.
fn changed(dict: &Dictionary, image: &[u8], scope: Option<Scope>, salt: u8) -> Vec<u8> {
    let mut out = image.to_vec();
    for e in dict.entries.iter().filter(|e| stored(e) && scope.is_none_or(|s| s == scope_of(e.index))) {
        for (i, b) in out[e.range()].iter_mut().enumerate() {
            *b ^= salt.wrapping_add(i as u8) | 1;
        }
    }
    out
}

/// The image a power-on loads from `storage` (a copy, with the power cycled:
/// what the adapter held in RAM is gone), starting from `defaults`.
fn power_cycle_load(dict: &Dictionary, defaults: &[u8], storage: &MemStorage) -> (Vec<u8>, MemStorage) {
    let mut storage = storage.clone();
    storage.cut_after(0);
    storage.power_on();
    let mut image = defaults.to_vec();
    let set = store::newest(dict, &mut storage).expect("a stored set");
    for part in [Part::Communication, Part::Application] {
        set.load(dict, &mut image, ID, &mut storage, part);
    }
    (image, storage)
}

/// The stored entries whose bytes differ between `a` and `b`, as `index:sub`.
fn differing(dict: &Dictionary, a: &[u8], b: &[u8]) -> Vec<String> {
    dict.entries
        .iter()
        .filter(|e| stored(e) && a[e.range()] != b[e.range()])
        .map(|e| format!("{:#06x}:{}", { e.index }, { e.sub }))
        .collect()
}

fn no_violations(storage: &MemStorage, what: &str) {
    assert!(storage.violations().is_empty(), "{what}: flash rules broken: {:?}", storage.violations());
}

/// Save all, power cycle, every stored entry back; then each partial save
/// over that set; then LSS "store configuration" twice over it.
fn round_trip(name: &str, dict: &Dictionary, defaults: &[u8], layout: Layout) {
    let mut storage = MemStorage::with_layout(layout);
    let all = changed(dict, defaults, None, 0x5A);
    store::save(dict, &all, ID, &mut storage, Scope::All).unwrap_or_else(|e| panic!("{name}: save all: {e:?}"));
    no_violations(&storage, name);
    let (loaded, _) = power_cycle_load(dict, defaults, &storage);
    let lost = differing(dict, &loaded, &all);
    let count = dict.entries.iter().filter(|e| stored(e)).count();
    assert!(lost.is_empty(), "{name}: {} of {count} stored entries did not come back: {lost:?}", lost.len());
    assert_eq!(loaded, all, "{name}: the loaded image is the saved one");

    // 0x1010 sub 2, 4, 3: only that scope changes; the rest stays as stored.
    let mut expected = all.clone();
    for (scope, salt) in [(Scope::Communication, 0x21), (Scope::Manufacturer, 0x42), (Scope::Application, 0x63)] {
        let image = changed(dict, &expected, Some(scope), salt);
        let mut other = changed(dict, &image, None, 0x0F);
        // The node's RAM holds the new scope; the other scopes' RAM values are not saved.
        for e in dict.entries.iter().filter(|e| stored(e) && scope_of(e.index) == scope) {
            other[e.range()].copy_from_slice(&image[e.range()]);
        }
        store::save(dict, &other, ID, &mut storage, scope).unwrap_or_else(|e| panic!("{name}: save {scope:?}: {e:?}"));
        no_violations(&storage, name);
        expected = image;
        let (loaded, _) = power_cycle_load(dict, defaults, &storage);
        let wrong = differing(dict, &loaded, &expected);
        assert!(wrong.is_empty(), "{name}: after the {scope:?} save, wrong entries: {wrong:?}");
    }

    // LSS "store configuration" over the stored set, twice: the parameters stay.
    for (node_id, rate) in [(9, 2), (10, 4)] {
        store::save_lss(dict, &changed(dict, defaults, None, 0x33), ID, &mut storage, node_id, rate)
            .unwrap_or_else(|e| panic!("{name}: LSS store: {e:?}"));
        no_violations(&storage, name);
        let (loaded, mut cycled) = power_cycle_load(dict, defaults, &storage);
        assert_eq!(store::newest(dict, &mut cycled).and_then(|s| s.lss()), Some((node_id, rate)), "{name}: LSS configuration");
        assert!(differing(dict, &loaded, &expected).is_empty(), "{name}: LSS store kept the parameters");
    }
}

/// A power cut at every erase and program of a save over an older set:
/// after it the node loads the old set or the new one, whole.
fn power_cut_at_every_step(name: &str, dict: &Dictionary, defaults: &[u8], layout: Layout) {
    let mut base = MemStorage::with_layout(layout);
    let old = changed(dict, defaults, None, 0x11);
    let new = changed(dict, defaults, None, 0x77);
    store::save(dict, &old, ID, &mut base, Scope::All).unwrap();
    let mut probe = base.clone();
    let before = probe.steps();
    store::save(dict, &new, ID, &mut probe, Scope::All).unwrap();
    let steps = probe.steps() - before;
    // One step per page erased and per half-word programmed.
    let pages = u64::from(layout.pages_per_set());
    assert_eq!(steps, pages + (dict.stored_len as u64 + 24).div_ceil(2), "{name}: steps of a save");
    let (mut got_old, mut got_new) = (0, 0);
    for k in 1..=steps {
        let mut s = base.clone();
        s.cut_after(k);
        assert!(store::save(dict, &new, ID, &mut s, Scope::All).is_err(), "{name}: the cut at step {k} is reported");
        s.power_on();
        no_violations(&s, name);
        let (loaded, _) = power_cycle_load(dict, defaults, &s);
        if loaded == old {
            got_old += 1;
        } else {
            assert_eq!(loaded, new, "{name}: cut at step {k} of {steps} loads a mix");
            got_new += 1;
        }
        // And the next save after the cut works.
        store::save(dict, &new, ID, &mut s, Scope::All).unwrap_or_else(|e| panic!("{name}: save after a cut at {k}: {e:?}"));
        no_violations(&s, name);
        assert_eq!(power_cycle_load(dict, defaults, &s).0, new, "{name}: save after a cut at {k}");
    }
    // The header goes last, so a cut before its last half-word keeps the old set.
    assert!(got_old >= steps - 1, "{name}: {got_old} cuts kept the old set, {got_new} the new one, of {steps}");
}

macro_rules! devices {
    ($($device:ident),*) => {
        $(
            mod $device {
                use super::*;
                use firmware::devices::$device::od;

                fn parts() -> (&'static Dictionary, Vec<u8>) {
                    let ram = od::Ram::new(ID);
                    (ram.dictionary(), ram.image().to_vec())
                }

                #[test]
                fn every_stored_entry_survives_a_save_and_a_power_cycle_on_1k_pages() {
                    let (dict, defaults) = parts();
                    round_trip(stringify!($device), dict, &defaults, Layout::stm32f103c8(region_size(od::STORED_SIZE)));
                }

                #[test]
                fn every_stored_entry_survives_on_2k_pages() {
                    let (dict, defaults) = parts();
                    let region = region_size(od::STORED_SIZE) as u32;
                    round_trip(stringify!($device), dict, &defaults, Layout { base: 124 * 1024, page: 2048, stride: 2048, region });
                }

                #[test]
                fn a_power_cut_at_every_step_of_a_save_keeps_a_whole_set() {
                    let (dict, defaults) = parts();
                    power_cut_at_every_step(stringify!($device), dict, &defaults, Layout::stm32f103c8(region_size(od::STORED_SIZE)));
                }
            }
        )*
    };
}

devices!(ec5000, unitek_ds, sendix, bmaxx4400, agile);

/// Erases per store on the F103C8: one page where the set fits one.
#[test]
fn a_store_erases_one_page_where_the_set_fits_one() {
    use firmware::devices::{agile, bmaxx4400, ec5000, sendix, unitek_ds};
    let pages =
        [ec5000::od::STORED_SIZE, unitek_ds::od::STORED_SIZE, sendix::od::STORED_SIZE, bmaxx4400::od::STORED_SIZE, agile::od::STORED_SIZE]
            .map(|n| Layout::stm32f103c8(region_size(n)).pages_per_set());
    assert_eq!(pages, [1, 1, 1, 1, 1]);
}

/// On the F103C8 the storage takes the pages its sets need and the program
/// the rest: region 0 starts where each STM32 image's `memory.x` flash ends
/// (firmware/build.rs gives the linker `__storage_kib` from the stored set
/// od-gen computes), region 1 right after it, and both end at 64 KiB.
#[test]
fn each_images_storage_starts_where_its_program_flash_ends() {
    use firmware::boards::stm32f103::{LINKED_STORAGE_KIB, program_flash};
    let mut regions = Vec::new();
    for device in &firmware::devices::ALL {
        let image = format!("{}-stm32f103", device.name);
        let layout = Layout::stm32f103c8(region_size(device.dictionary.stored_len));
        let linked = LINKED_STORAGE_KIB.iter().find(|(name, _)| *name == image).map(|&(_, kib)| kib);
        assert_eq!(linked.map(|kib| 64 * 1024 - kib * 1024), Some(layout.base), "{image}: build.rs and the layout disagree");
        assert_eq!(program_flash(&image), layout.base, "{image}");
        assert_eq!(layout.base + 2 * layout.stride, 64 * 1024, "{image}: region 1 ends the flash");
        regions.push((device.name, layout.base / 1024, layout.stride / 1024));
    }
    assert_eq!(
        regions,
        [("ec5000", 62, 1), ("unitek-ds", 62, 1), ("sendix", 62, 1), ("bmaxx4400", 62, 1), ("agile", 62, 1)],
        "(device, program KiB, KiB per region)"
    );
    assert_eq!(program_flash("my-device"), 60 * 1024, "an image of your own keeps 4 KiB for its storage");
}

/// The same through the node: SDO 0x1017 = 50 ms, 0x1010 sub 2 "save",
/// power cycle, and 0x1017 is 50 ms; then LSS "store configuration" with a
/// stored set gives the stored node-id after the next power cycle.
#[test]
fn ec5000_heartbeat_saved_by_sdo_comes_back_and_lss_stores_over_it() {
    use firmware::devices::ec5000::od;
    type Ec5000 = Bench<od::Ram, NoApplication, MemStorage, { od::RPDO_COUNT }, { od::TPDO_COUNT }, { od::HB_CONSUMER_COUNT }>;
    let storage = MemStorage::with_layout(Layout::stm32f103c8(region_size(od::STORED_SIZE)));
    let mut b: Ec5000 = Bench::new(od::Ram::new(ID), NoApplication, storage, ID);
    b.at(ms(0));
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &50u16.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1010, 1, b"save"), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1017, 0, &70u16.to_le_bytes()), Ok(()));
    assert_eq!(b.sdo_download(ID, 0x1010, 2, b"save"), Ok(()), "a partial save over a stored set");
    let mut storage = b.node.storage_mut().clone();
    no_violations(&storage, "ec5000");
    storage.cut_after(0);
    storage.power_on();
    let mut b: Ec5000 = Bench::new(od::Ram::new(ID), NoApplication, storage, ID);
    b.at(ms(0));
    assert_eq!(b.sdo_upload(ID, 0x1017, 0), Ok(70u16.to_le_bytes().to_vec()), "0x1017 after the power cycle");
    // LSS: switch state global, configure node-id 9, store configuration.
    const LSS: u16 = 0x7E5;
    b.rx(ms(10), LSS, &[0x04, 0x01, 0, 0, 0, 0, 0, 0]);
    assert_eq!(b.rx(ms(11), LSS, &[0x11, 9, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x11, 0, 0, 0, 0, 0, 0, 0])]);
    assert_eq!(b.rx(ms(12), LSS, &[0x17, 0, 0, 0, 0, 0, 0, 0]), [(0x7E4, vec![0x17, 0, 0, 0, 0, 0, 0, 0])], "store configuration succeeds");
    let mut storage = b.node.storage_mut().clone();
    no_violations(&storage, "ec5000");
    storage.cut_after(0);
    storage.power_on();
    let mut b: Ec5000 = Bench::new(od::Ram::new(ID), NoApplication, storage, ID);
    assert_eq!(b.at(ms(0)), [(0x709, vec![0x00])], "boot-up as the stored node 9");
    assert_eq!(b.sdo_upload(9, 0x1017, 0), Ok(70u16.to_le_bytes().to_vec()), "the parameters stayed");
}

/// The core's own store tests (`services/store/tests.rs`, which run on a
/// byte-wise fake flash) again on the part's rules: their small dictionary
/// puts values at odd offsets 1, 3, 7 and 11, and `$NODEID` at 3.
mod core_store_scenarios {
    use super::*;
    use canopen_core::od::{DataType, DeviceInfo};

    const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
    const RW_N: Attr = Attr(RW.0 | Attr::NODE_ID.0);
    static ENTRIES: [Entry; 5] = [
        Entry::new(0x1001, 0, DataType::Unsigned8, Attr::READ, 1, 0),
        Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 1),
        Entry::new(0x1800, 1, DataType::Unsigned32, RW_N, 4, 3),
        Entry::new(0x2000, 0, DataType::Unsigned32, RW, 4, 7),
        Entry::new(0x6060, 0, DataType::Integer8, RW, 1, 11),
    ];
    static DEFAULTS: [u8; 12] = [0, 0, 0, 0x80, 0x01, 0, 0x40, 1, 0, 0, 0, 3];
    static DICT: Dictionary = Dictionary {
        entries: &ENTRIES,
        limits: &[],
        limit_rows: &[],
        rom: &[],
        defaults: canopen_core::od::Defaults::dense(&DEFAULTS),
        comm_len: 7,
        stored_len: 12,
        comm_rest: 0,
        node_id_relative: &[2],
        layout_id: canopen_core::od::layout_id(&ENTRIES),
        device: DeviceInfo {
            baud_rates: 0,
            lss_supported: false,
            granularity: 8,
            simple_boot_up_slave: false,
            dynamic_channels: false,
            group_messaging: false,
        },
    };

    fn flash() -> MemStorage {
        MemStorage::with_layout(Layout::stm32f103c8(region_size(DEFAULTS.len())))
    }

    /// Power-on: the defaults, then both parts from the stored set (the adapter's RAM is gone).
    fn boot(storage: &MemStorage, node_id: u8) -> [u8; 12] {
        let mut s = storage.clone();
        s.cut_after(0);
        s.power_on();
        let mut img = [0u8; 12];
        DICT.reset_application(&mut img, node_id);
        store::load(&DICT, &mut img, node_id, &mut s, Part::Application);
        DICT.reset_communication(&mut img, node_id);
        store::load(&DICT, &mut img, node_id, &mut s, Part::Communication);
        img
    }

    fn read(img: &[u8], index: u16, sub: u8) -> Vec<u8> {
        DICT.read(img, index, sub).unwrap().to_vec()
    }

    #[test]
    fn a_saved_set_survives_a_power_cycle_and_follows_the_node_id() {
        let mut s = flash();
        let mut img = boot(&s, 5);
        DICT.write(&mut img, 0x1017, 0, &500u16.to_le_bytes()).unwrap();
        DICT.write(&mut img, 0x2000, 0, &7u32.to_le_bytes()).unwrap();
        DICT.write(&mut img, 0x1800, 1, &0x4000_0285u32.to_le_bytes()).unwrap();
        store::save(&DICT, &img, 5, &mut s, Scope::All).unwrap();
        let img = boot(&s, 9);
        assert_eq!(read(&img, 0x1017, 0), 500u16.to_le_bytes());
        assert_eq!(read(&img, 0x2000, 0), 7u32.to_le_bytes());
        assert_eq!(read(&img, 0x1800, 1), 0x4000_0289u32.to_le_bytes(), "stored relative to the node-id");
        no_violations(&s, "core scenario");
    }

    #[test]
    fn scopes_store_and_restore_their_own_range() {
        let mut s = flash();
        let mut img = boot(&s, 1);
        DICT.write(&mut img, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
        DICT.write(&mut img, 0x2000, 0, &42u32.to_le_bytes()).unwrap();
        DICT.write(&mut img, 0x6060, 0, &[1]).unwrap();
        store::save(&DICT, &img, 1, &mut s, Scope::Communication).unwrap();
        let img2 = boot(&s, 1);
        assert_eq!(read(&img2, 0x1017, 0), 100u16.to_le_bytes());
        assert_eq!(read(&img2, 0x2000, 0), 1u32.to_le_bytes(), "manufacturer scope not stored");
        store::save(&DICT, &img, 1, &mut s, Scope::Manufacturer).unwrap();
        let img3 = boot(&s, 1);
        assert_eq!(read(&img3, 0x2000, 0), 42u32.to_le_bytes());
        assert_eq!(read(&img3, 0x1017, 0), 100u16.to_le_bytes(), "earlier communication set kept");
        assert_eq!(read(&img3, 0x6060, 0), [3], "application scope still default");
        store::restore_defaults(&DICT, &img, 1, &mut s, Scope::All).unwrap();
        assert_eq!(boot(&s, 1), boot(&flash(), 1));
        no_violations(&s, "core scenario");
    }

    #[test]
    fn a_power_cut_at_any_step_leaves_the_old_or_the_new_set() {
        let mut base = flash();
        let mut img = boot(&base, 3);
        DICT.write(&mut img, 0x1017, 0, &111u16.to_le_bytes()).unwrap();
        DICT.write(&mut img, 0x2000, 0, &1111u32.to_le_bytes()).unwrap();
        store::save(&DICT, &img, 3, &mut base, Scope::All).unwrap();
        DICT.write(&mut img, 0x1017, 0, &222u16.to_le_bytes()).unwrap();
        DICT.write(&mut img, 0x2000, 0, &2222u32.to_le_bytes()).unwrap();
        let mut probe = base.clone();
        let before = probe.steps();
        store::save(&DICT, &img, 3, &mut probe, Scope::All).unwrap();
        let steps = probe.steps() - before;
        assert_eq!(steps, 1 + 18, "one page, 18 half-words (24-byte header + 12-byte image)");
        let (mut old, mut new) = (0, 0);
        for cut in 1..=steps + 1 {
            let mut s = base.clone();
            s.cut_after(cut);
            let result = store::save(&DICT, &img, 3, &mut s, Scope::All);
            let after = boot(&s, 3);
            if read(&after, 0x1017, 0) == 111u16.to_le_bytes() {
                assert_eq!(read(&after, 0x2000, 0), 1111u32.to_le_bytes(), "cut {cut}: a mix");
                assert!(result.is_err());
                old += 1;
            } else {
                assert_eq!(
                    (read(&after, 0x1017, 0), read(&after, 0x2000, 0)),
                    (222u16.to_le_bytes().to_vec(), 2222u32.to_le_bytes().to_vec())
                );
                new += 1;
            }
            no_violations(&s, "core scenario");
        }
        assert!(old > 0 && new > 0);
    }

    #[test]
    fn lss_configuration_is_stored_with_the_set_and_survives_power_cuts() {
        let mut s = flash();
        let mut img = boot(&s, 127);
        DICT.write(&mut img, 0x1017, 0, &300u16.to_le_bytes()).unwrap();
        store::save(&DICT, &img, 127, &mut s, Scope::All).unwrap();
        store::save_lss(&DICT, &img, 127, &mut s, 0x20, 3).unwrap();
        assert_eq!(store::newest(&DICT, &mut s).and_then(|set| set.lss()), Some((0x20, 3)));
        let img = boot(&s, 0x20);
        assert_eq!(read(&img, 0x1017, 0), 300u16.to_le_bytes());
        store::save(&DICT, &img, 0x20, &mut s, Scope::Communication).unwrap();
        assert_eq!(store::newest(&DICT, &mut s).and_then(|set| set.lss()), Some((0x20, 3)));
        for cut in 1..=20 {
            let mut f = s.clone();
            f.cut_after(cut);
            let _ = store::save_lss(&DICT, &img, 0x20, &mut f, 0x21, 4);
            f.power_on();
            let got = store::newest(&DICT, &mut f).and_then(|set| set.lss());
            assert!(got == Some((0x20, 3)) || got == Some((0x21, 4)), "cut {cut}: {got:?}");
            no_violations(&f, "core scenario");
        }
    }
}

/// The b maXX 4400's set holds its writable values alone: every read-only
/// RAM value (actual values the drive computes) changed does not change a
/// byte of the flash after a save, the header's length is `STORED_SIZE`,
/// and the set with its header fits one 1 KiB page.
#[test]
fn bmaxx4400_read_only_values_are_not_in_the_set() {
    use firmware::devices::bmaxx4400::od;
    let dict = &od::DICTIONARY;
    let layout = Layout::stm32f103c8(region_size(od::STORED_SIZE));
    let defaults = od::Ram::new(ID).image().to_vec();
    let read_only: Vec<&Entry> = dict.entries.iter().filter(|e| !e.in_rom() && e.len > 0 && !stored(e)).collect();
    assert!(read_only.len() > 10, "the drive has read-only values in RAM");
    let mut touched = defaults.clone();
    for e in &read_only {
        touched[e.range()].iter_mut().for_each(|b| *b ^= 0x5A);
    }
    let (mut a, mut b) = (MemStorage::with_layout(layout), MemStorage::with_layout(layout));
    store::save(dict, &defaults, ID, &mut a, Scope::All).unwrap();
    store::save(dict, &touched, ID, &mut b, Scope::All).unwrap();
    assert_eq!(a.region(0), b.region(0), "the read-only values are not in the set");
    let set = a.region(0).unwrap();
    assert_eq!(usize::from(u16::from_le_bytes([set[16], set[17]])), od::STORED_SIZE, "the header's length");
    const { assert!(od::STORED_SIZE < od::RAM_SIZE && od::STORED_SIZE + 24 <= 1024, "the set with its header fits a page") };
    assert_eq!(layout.pages_per_set(), 1);
    for e in read_only {
        assert_eq!(store::stored_value(dict, &mut a, ID, e.index, e.sub, &mut [0; 256]), None, "{:#06x}:{}", { e.index }, { e.sub });
    }
}
