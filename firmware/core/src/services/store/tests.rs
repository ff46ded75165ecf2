//! Store/restore on a flash-like storage with a power cut at every step.

use super::*;
use crate::od::{DataType, DeviceInfo, Entry};

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
    defaults: crate::od::Defaults::dense(&DEFAULTS),
    comm_len: 7,
    stored_len: 12,
    comm_rest: 0,
    node_id_relative: &[2],
    layout_id: crate::od::layout_id(&ENTRIES),
    device: DeviceInfo {
        baud_rates: 0,
        lss_supported: false,
        granularity: 8,
        simple_boot_up_slave: false,
        dynamic_channels: false,
        group_messaging: false,
    },
};

/// Bytes per region of [`Flash`]: room for the header and [`LONGEST`]'s 206-byte image.
const REGION: usize = 256;

/// NOR-flash-like memory whose power can be cut after `budget` steps.
struct Flash {
    regions: [[u8; REGION]; 2],
    budget: Option<usize>,
}

impl Flash {
    fn new() -> Self {
        Flash { regions: [[0xFF; REGION]; 2], budget: None }
    }

    fn step(&mut self) -> Result<bool, StorageError> {
        match &mut self.budget {
            Some(0) => Err(StorageError::Failed),
            Some(n) => {
                *n -= 1;
                // The step that exhausts the budget is cut halfway.
                Ok(*n == 0)
            }
            None => Ok(false),
        }
    }
}

impl Storage for Flash {
    fn region_size(&self) -> usize {
        REGION
    }
    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let r = self.regions.get(usize::from(region)).ok_or(StorageError::OutOfRange)?;
        buf.copy_from_slice(r.get(offset..offset + buf.len()).ok_or(StorageError::OutOfRange)?);
        Ok(())
    }
    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        let cut = self.step()?;
        let r = self.regions.get_mut(usize::from(region)).ok_or(StorageError::OutOfRange)?;
        let n = if cut { r.len() / 2 } else { r.len() };
        r[..n].fill(0xFF);
        if cut { Err(StorageError::Failed) } else { Ok(()) }
    }
    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        let cut = self.step()?;
        let r = self.regions.get_mut(usize::from(region)).ok_or(StorageError::OutOfRange)?;
        let dst = r.get_mut(offset..offset + data.len()).ok_or(StorageError::OutOfRange)?;
        let n = if cut { data.len() / 2 } else { data.len() };
        for (d, s) in dst.iter_mut().zip(&data[..n]) {
            *d &= *s;
        }
        if cut { Err(StorageError::Failed) } else { Ok(()) }
    }
}

fn boot(flash: &mut Flash, node_id: u8) -> [u8; 12] {
    let mut img = [0u8; 12];
    DICT.reset_application(&mut img, node_id);
    load(&DICT, &mut img, node_id, flash, Part::Application);
    DICT.reset_communication(&mut img, node_id);
    load(&DICT, &mut img, node_id, flash, Part::Communication);
    img
}

#[test]
fn a_saved_set_survives_a_reboot_and_follows_the_node_id() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 5);
    assert_eq!(DICT.read(&img, 0x1800, 1), Ok(&0x4000_0185u32.to_le_bytes()[..]));
    DICT.write(&mut img, 0x1017, 0, &500u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &7u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x1800, 1, &0x4000_0285u32.to_le_bytes()).unwrap();
    save(&DICT, &img, 5, &mut flash, Scope::All).unwrap();
    let img = boot(&mut flash, 9);
    assert_eq!(DICT.read(&img, 0x1017, 0), Ok(&500u16.to_le_bytes()[..]));
    assert_eq!(DICT.read(&img, 0x2000, 0), Ok(&7u32.to_le_bytes()[..]));
    assert_eq!(DICT.read(&img, 0x1800, 1), Ok(&0x4000_0289u32.to_le_bytes()[..]), "stored relative to the node-id");
}

#[test]
fn scopes_store_and_restore_their_own_range() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    DICT.write(&mut img, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &42u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x6060, 0, &[1]).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::Communication).unwrap();
    let img2 = boot(&mut flash, 1);
    assert_eq!(DICT.read(&img2, 0x1017, 0), Ok(&100u16.to_le_bytes()[..]));
    assert_eq!(DICT.read(&img2, 0x2000, 0), Ok(&1u32.to_le_bytes()[..]), "manufacturer scope not stored");
    save(&DICT, &img, 1, &mut flash, Scope::Manufacturer).unwrap();
    let img3 = boot(&mut flash, 1);
    assert_eq!(DICT.read(&img3, 0x2000, 0), Ok(&42u32.to_le_bytes()[..]));
    assert_eq!(DICT.read(&img3, 0x1017, 0), Ok(&100u16.to_le_bytes()[..]), "earlier communication set kept");
    assert_eq!(DICT.read(&img3, 0x6060, 0), Ok(&[3][..]), "application scope still default");
    restore_defaults(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    let img4 = boot(&mut flash, 1);
    assert_eq!(img4, boot(&mut Flash::new(), 1));
}

#[test]
fn objects_saved_after_a_restore_keep_the_rest_of_their_scope_at_default() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    DICT.write(&mut img, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x1800, 1, &0x4000_0281u32.to_le_bytes()).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::Communication).unwrap();
    restore_defaults(&DICT, &img, 1, &mut flash, Scope::Communication).unwrap();
    // A device stores one object of the restored scope before the reset (an encoder's operating time).
    DICT.write(&mut img, 0x1017, 0, &200u16.to_le_bytes()).unwrap();
    save_objects(&DICT, &img, 1, &mut flash, 0x1017, 0x1017).unwrap();
    let img = boot(&mut flash, 1);
    assert_eq!(DICT.read(&img, 0x1017, 0), Ok(&200u16.to_le_bytes()[..]));
    assert_eq!(DICT.read(&img, 0x1800, 1), Ok(&0x4000_0181u32.to_le_bytes()[..]), "the restore holds for the rest");
}

/// One step composes values from all three sources: after a restore of
/// the communication scope, storing 0x1017 alone takes 0x1001 and 0x1800
/// from the defaults (read once, to the step's end), 0x1017 from the image,
/// and 0x2000 and 0x6060 from the set, over the defaults read before them.
#[test]
fn one_step_takes_defaults_image_and_stored_values_each_where_they_belong() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    DICT.write(&mut img, 0x1800, 1, &0x4000_0281u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &42u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x6060, 0, &[7]).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    restore_defaults(&DICT, &img, 1, &mut flash, Scope::Communication).unwrap();
    DICT.write(&mut img, 0x1017, 0, &200u16.to_le_bytes()).unwrap();
    // A change not saved: the set's value stays.
    DICT.write(&mut img, 0x2000, 0, &43u32.to_le_bytes()).unwrap();
    save_objects(&DICT, &img, 1, &mut flash, 0x1017, 0x1017).unwrap();
    let loaded = boot(&mut flash, 1);
    assert_eq!(DICT.read(&loaded, 0x1017, 0), Ok(&200u16.to_le_bytes()[..]));
    assert_eq!(DICT.read(&loaded, 0x1800, 1), Ok(&0x4000_0181u32.to_le_bytes()[..]), "the restored default");
    assert_eq!(DICT.read(&loaded, 0x2000, 0), Ok(&42u32.to_le_bytes()[..]), "the stored value");
    assert_eq!(DICT.read(&loaded, 0x6060, 0), Ok(&[7][..]), "the stored value");
}

#[test]
fn storing_one_object_after_a_restore_keeps_the_other_defaults() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    DICT.write(&mut img, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    restore_defaults(&DICT, &img, 1, &mut flash, Scope::Communication).unwrap();
    // A device keeps a read-only value of the same scope (a counter) after the restore.
    img[0] = 9;
    save_objects(&DICT, &img, 1, &mut flash, 0x1001, 0x1001).unwrap();
    let img2 = boot(&mut flash, 1);
    assert_eq!(DICT.read(&img2, 0x1017, 0), Ok(&0u16.to_le_bytes()[..]), "the restored default, not the value before");
    assert_eq!(stored_value(&DICT, &mut flash, 1, 0x1001, 0, &mut [0]), Some(1));
    let mut v = [0];
    stored_value(&DICT, &mut flash, 1, 0x1001, 0, &mut v);
    assert_eq!(v, [9]);
}

/// A save that keeps objects (a device's `not_saved_by_1010`) takes every
/// other one from the image: kept ranges at either end of the indices, in
/// the middle, all of them, and an empty (reversed) one.
#[test]
fn a_save_keeping_objects_takes_all_others_from_the_image() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    DICT.write(&mut img, 0x1017, 0, &100u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &42u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x6060, 0, &[1]).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    DICT.write(&mut img, 0x1017, 0, &200u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &43u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x6060, 0, &[2]).unwrap();
    let saved = |keep: Option<(u16, u16)>| {
        let mut f = Flash { regions: flash.regions, budget: None };
        save_except(&DICT, &img, 1, &mut f, Scope::All, keep).unwrap();
        let loaded = boot(&mut f, 1);
        [(0x1017, 0, 200), (0x2000, 0, 43), (0x6060, 0, 2)].map(|(index, sub, new)| {
            let v = DICT.read(&loaded, index, sub).unwrap();
            v.first() == Some(&new)
        })
    };
    assert_eq!(saved(None), [true; 3]);
    assert_eq!(saved(Some((0x2000, 0x2000))), [true, false, true]);
    assert_eq!(saved(Some((0x0000, 0x1FFF))), [false, true, true]);
    assert_eq!(saved(Some((0x2000, 0xFFFF))), [true, false, false]);
    assert_eq!(saved(Some((0x1800, 0x6060))), [true, false, false]);
    assert_eq!(saved(Some((0x0000, 0xFFFF))), [false; 3]);
    assert_eq!(saved(Some((0x6060, 0x1017))), [true; 3], "an empty range keeps none");
}

#[test]
fn a_power_cut_at_any_step_leaves_the_old_or_the_new_set() {
    // Old set: 0x1017 = 111, 0x2000 = 1111. New set: 222, 2222.
    let mut base = Flash::new();
    let mut img = boot(&mut base, 3);
    DICT.write(&mut img, 0x1017, 0, &111u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &1111u32.to_le_bytes()).unwrap();
    save(&DICT, &img, 3, &mut base, Scope::All).unwrap();
    DICT.write(&mut img, 0x1017, 0, &222u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &2222u32.to_le_bytes()).unwrap();
    // Count the steps of one save, then cut at each of them.
    let steps = {
        let mut f = Flash { regions: base.regions, budget: Some(usize::MAX) };
        save(&DICT, &img, 3, &mut f, Scope::All).unwrap();
        usize::MAX - f.budget.unwrap()
    };
    // Erase, payload (a piece), header: a cut at each.
    assert!(steps >= 3);
    let (mut old, mut new) = (0, 0);
    for cut in 1..=steps + 1 {
        let mut f = Flash { regions: base.regions, budget: Some(cut) };
        let result = save(&DICT, &img, 3, &mut f, Scope::All);
        f.budget = None;
        let after = boot(&mut f, 3);
        let hb = DICT.read(&after, 0x1017, 0).unwrap().to_vec();
        let param = DICT.read(&after, 0x2000, 0).unwrap().to_vec();
        if hb == 111u16.to_le_bytes() {
            assert_eq!(param, 1111u32.to_le_bytes(), "cut {cut}: a mix");
            assert!(result.is_err());
            old += 1;
        } else {
            assert_eq!((hb, param), (222u16.to_le_bytes().to_vec(), 2222u32.to_le_bytes().to_vec()), "cut {cut}");
            new += 1;
        }
    }
    assert!(old > 0 && new > 0);
}

#[test]
fn a_set_for_another_layout_or_a_too_small_storage_is_refused() {
    let mut flash = Flash::new();
    let img = boot(&mut flash, 1);
    flash.regions[0][..4].copy_from_slice(&MAGIC.to_le_bytes());
    assert!(newest(&DICT, &mut flash).is_none());
    assert_eq!(Scope::from_sub(5), None);
    assert_eq!(Scope::from_sub(2), Some(Scope::Communication));
    struct Tiny;
    impl Storage for Tiny {
        fn region_size(&self) -> usize {
            8
        }
        fn read(&mut self, _: u8, _: usize, _: &mut [u8]) -> Result<(), StorageError> {
            Err(StorageError::Failed)
        }
        fn erase(&mut self, _: u8) -> Result<(), StorageError> {
            Ok(())
        }
        fn write(&mut self, _: u8, _: usize, _: &[u8]) -> Result<(), StorageError> {
            Ok(())
        }
    }
    assert_eq!(save(&DICT, &img, 1, &mut Tiny, Scope::All), Err(StoreError::TooLarge));
}

#[test]
fn lss_configuration_is_stored_with_the_set_and_survives_power_cuts() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 127);
    assert_eq!(newest(&DICT, &mut flash).and_then(|set| set.lss()), None);
    DICT.write(&mut img, 0x1017, 0, &300u16.to_le_bytes()).unwrap();
    save(&DICT, &img, 127, &mut flash, Scope::All).unwrap();
    save_lss(&DICT, &img, 127, &mut flash, 0x20, 3).unwrap();
    assert_eq!(newest(&DICT, &mut flash).and_then(|set| set.lss()), Some((0x20, 3)));
    // The parameters stored before are still there, and a later save keeps the LSS part.
    let img = boot(&mut flash, 0x20);
    assert_eq!(DICT.read(&img, 0x1017, 0), Ok(&300u16.to_le_bytes()[..]));
    save(&DICT, &img, 0x20, &mut flash, Scope::Communication).unwrap();
    assert_eq!(newest(&DICT, &mut flash).and_then(|set| set.lss()), Some((0x20, 3)));
    // A cut at any step of the next LSS store leaves (0x20, 3) or (0x21, 4).
    let base = flash.regions;
    for cut in 1..12 {
        let mut f = Flash { regions: base, budget: Some(cut) };
        let _ = save_lss(&DICT, &img, 0x20, &mut f, 0x21, 4);
        f.budget = None;
        let got = newest(&DICT, &mut f).and_then(|set| set.lss());
        assert!(got == Some((0x20, 3)) || got == Some((0x21, 4)), "cut {cut}: {got:?}");
    }
}

#[test]
fn the_crc_is_crc32_ieee_in_any_chunking() {
    let data = b"123456789";
    assert_eq!(!crc32_update(!0, data), 0xCBF4_3926);
    assert_eq!(!crc32_update(crc32_update(!0, &data[..4]), &data[4..]), 0xCBF4_3926);
    assert_eq!(!crc32_update(!0, &[]), 0);
}

#[test]
fn the_layout_id_is_the_fnv_1a_of_the_entry_table_as_before() {
    // The run-time hash the store computed before the id moved into the
    // dictionary: sets stored then must still be recognised (the length
    // hashed as the 16 bits an entry held before it became one byte).
    let mut h: u32 = 0x811C_9DC5;
    for e in &ENTRIES {
        for b in [
            e.index.to_le_bytes().as_slice(),
            &[e.sub, e.data_type as u8, e.attr.0 & !Attr::SCOPE.0],
            &u16::from(e.len).to_le_bytes(),
            &e.offset.to_le_bytes(),
        ] {
            for &x in b {
                h = (h ^ u32::from(x)).wrapping_mul(0x0100_0193);
            }
        }
    }
    assert_eq!(DICT.layout_id, h);
    assert_ne!(crate::od::layout_id(&ENTRIES[..4]), h, "another table, another id");
    // A set written under another layout id is not used.
    let mut flash = Flash::new();
    let img = boot(&mut flash, 1);
    save(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    assert!(newest(&DICT, &mut flash).is_some());
    flash.regions[0][8] ^= 1;
    assert!(newest(&DICT, &mut flash).is_none());
}

/// [`Flash`] counting the bytes read.
struct Counting<'a>(&'a mut Flash, usize);

impl Storage for Counting<'_> {
    fn region_size(&self) -> usize {
        self.0.region_size()
    }
    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        self.1 += buf.len();
        self.0.read(region, offset, buf)
    }
    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        self.0.erase(region)
    }
    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        self.0.write(region, offset, data)
    }
}

/// Two sets of node 1: the older (region 0, sequence 1) with 0x1017 = 111,
/// the newer (region 1, sequence 2) with 222; and the image as it stands.
fn two_sets() -> (Flash, [u8; 12]) {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    DICT.write(&mut img, 0x1017, 0, &111u16.to_le_bytes()).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    DICT.write(&mut img, 0x1017, 0, &222u16.to_le_bytes()).unwrap();
    save(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    (flash, img)
}

#[test]
fn the_newest_set_is_checked_alone_unless_its_payload_is_broken() {
    let (mut flash, _) = two_sets();
    // Both headers, then the newer payload only.
    let mut counting = Counting(&mut flash, 0);
    let set = newest(&DICT, &mut counting).unwrap();
    assert_eq!(counting.1, 2 * HEADER + DEFAULTS.len());
    assert_eq!((set.region, set.seq), (1, 2));
    assert_eq!(DICT.read(&boot(&mut flash, 1), 0x1017, 0), Ok(&222u16.to_le_bytes()[..]));
    // A newer set whose payload fails its CRC gives way to the older one.
    flash.regions[1][HEADER + 1] ^= 0x01;
    let mut counting = Counting(&mut flash, 0);
    let set = newest(&DICT, &mut counting).unwrap();
    // Both headers and a payload for each set checked ([`check`], one a call).
    assert_eq!(counting.1, 4 * HEADER + 2 * DEFAULTS.len());
    assert_eq!((set.region, set.seq), (0, 1));
    assert_eq!(DICT.read(&boot(&mut flash, 1), 0x1017, 0), Ok(&111u16.to_le_bytes()[..]));
}

/// A store over a broken newer set checks the sets in two steps, one CRC
/// each, so that no step reads more than both headers and one set's
/// payload; it follows the older set (its sequence number, its values).
#[test]
fn a_store_checks_one_set_per_step() {
    let (mut flash, mut img) = two_sets();
    flash.regions[1][HEADER + 1] ^= 0x01;
    // Stores 0x2000 alone: 0x1017 comes from the set the job follows.
    DICT.write(&mut img, 0x1017, 0, &333u16.to_le_bytes()).unwrap();
    let mut job = Job::save_objects(&DICT, 0x2000, 0x2000).unwrap();
    let mut reads = [0; 8];
    for (step, read) in reads.iter_mut().enumerate() {
        let mut counting = Counting(&mut flash, 0);
        let done = job.step(&DICT, &img, 1, &mut counting);
        *read = counting.1;
        assert!(counting.1 <= 2 * HEADER + DEFAULTS.len(), "step {step} read {} bytes", counting.1);
        if let Some(result) = done {
            assert_eq!(result, Ok(()));
            break;
        }
    }
    // The newer set's check, then the older one's, then the erase.
    assert_eq!(reads[..3], [2 * HEADER + DEFAULTS.len(), 2 * HEADER + DEFAULTS.len(), 0]);
    let set = newest(&DICT, &mut flash).unwrap();
    assert_eq!((set.region, set.seq), (1, 2));
    assert_eq!(DICT.read(&boot(&mut flash, 1), 0x1017, 0), Ok(&111u16.to_le_bytes()[..]));
}

#[test]
fn one_set_found_loads_both_parts() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 4);
    DICT.write(&mut img, 0x1017, 0, &700u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x1800, 1, &0x4000_0284u32.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x6060, 0, &[9]).unwrap();
    save(&DICT, &img, 4, &mut flash, Scope::All).unwrap();
    let set = newest(&DICT, &mut flash).unwrap();
    let mut fresh = [0u8; 12];
    DICT.reset_application(&mut fresh, 4);
    DICT.reset_communication(&mut fresh, 4);
    // The header says what is stored: the payload alone is read, each scope once.
    let mut counting = Counting(&mut flash, 0);
    assert!(set.load(&DICT, &mut fresh, 4, &mut counting, Part::Application));
    assert!(set.load(&DICT, &mut fresh, 4, &mut counting, Part::Communication));
    assert_eq!(counting.1, DEFAULTS.len(), "no header, no byte twice");
    assert_eq!(fresh, img);
    // A read-only value keeps its default, whatever the set holds for it (a value the device keeps itself).
    let mut other = img;
    other[0] = 9;
    save_objects(&DICT, &other, 4, &mut flash, 0x1001, 0x1001).unwrap();
    let set = newest(&DICT, &mut flash).unwrap();
    let mut fresh = [0u8; 12];
    DICT.reset_communication(&mut fresh, 4);
    assert!(set.load(&DICT, &mut fresh, 4, &mut flash, Part::Communication));
    assert_eq!((fresh[0], &fresh[1..7]), (0, &img[1..7]));
}

#[test]
fn a_storage_failure_while_loading_leaves_the_defaults() {
    struct Failing<'a>(&'a mut Flash);
    impl Storage for Failing<'_> {
        fn region_size(&self) -> usize {
            REGION
        }
        fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
            // A driver that fails after writing part of the buffer.
            self.0.read(region, offset, buf)?;
            buf.fill(0xEE);
            Err(StorageError::Failed)
        }
        fn erase(&mut self, _: u8) -> Result<(), StorageError> {
            Err(StorageError::Failed)
        }
        fn write(&mut self, _: u8, _: usize, _: &[u8]) -> Result<(), StorageError> {
            Err(StorageError::Failed)
        }
    }
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 2);
    DICT.write(&mut img, 0x1017, 0, &700u16.to_le_bytes()).unwrap();
    DICT.write(&mut img, 0x2000, 0, &5u32.to_le_bytes()).unwrap();
    save(&DICT, &img, 2, &mut flash, Scope::All).unwrap();
    let set = newest(&DICT, &mut flash).unwrap();
    let defaults = boot(&mut Flash::new(), 2);
    let mut fresh = defaults;
    assert!(!set.load(&DICT, &mut fresh, 2, &mut Failing(&mut flash), Part::Application));
    assert!(!set.load(&DICT, &mut fresh, 2, &mut Failing(&mut flash), Part::Communication));
    assert_eq!(fresh, defaults);
}

const LONG_ENTRIES: [Entry; 2] =
    [Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 0), Entry::new(0x2001, 0, DataType::OctetString, RW, 80, 2)];
/// A dictionary with a value longer than the chunks the store copies in.
static LONG: Dictionary = Dictionary {
    entries: &LONG_ENTRIES,
    defaults: crate::od::Defaults::dense(&[0; 82]),
    comm_len: 2,
    stored_len: 82,
    node_id_relative: &[],
    layout_id: crate::od::layout_id(&LONG_ENTRIES),
    ..DICT
};

#[test]
fn a_value_longer_than_a_chunk_is_stored_and_loaded_whole() {
    let mut flash = Flash::new();
    let mut img = [0u8; 82];
    let blob: [u8; 80] = core::array::from_fn(|i| i as u8 + 1);
    LONG.write(&mut img, 0x2001, 0, &blob).unwrap();
    LONG.write(&mut img, 0x1017, 0, &9u16.to_le_bytes()).unwrap();
    save(&LONG, &img, 1, &mut flash, Scope::All).unwrap();
    let mut fresh = [0u8; 82];
    for part in [Part::Application, Part::Communication] {
        assert!(load(&LONG, &mut fresh, 1, &mut flash, part));
    }
    assert_eq!(fresh, img);
}

#[test]
fn a_store_in_stages_takes_each_value_whole_from_the_image_of_one_step() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 1);
    let a = img;
    let mut b = img;
    DICT.write(&mut b, 0x1017, 0, &0x2222u16.to_le_bytes()).unwrap();
    DICT.write(&mut b, 0x1800, 1, &0x4000_0333u32.to_le_bytes()).unwrap();
    DICT.write(&mut b, 0x2000, 0, &0x4444_4444u32.to_le_bytes()).unwrap();
    DICT.write(&mut b, 0x6060, 0, &[0x55]).unwrap();
    // Steps of 3 bytes would cut 0x1800 sub 1 (bytes 3..7) and 0x2000 (7..11);
    // the image flips between the two versions after every step.
    let mut job = Job::save(Scope::All, None);
    let mut steps = 0;
    let result = loop {
        if let Some(result) = job.step_with(&DICT, &img, 1, &mut flash, 3) {
            break result;
        }
        steps += 1;
        img = if steps % 2 == 0 { a } else { b };
    };
    assert_eq!(result, Ok(()));
    assert!(steps > 4, "{steps} steps");
    let loaded = boot(&mut flash, 1);
    for (index, sub) in [(0x1017, 0), (0x1800, 1), (0x2000, 0), (0x6060, 0)] {
        let v = DICT.read(&loaded, index, sub).unwrap();
        assert!(v == DICT.read(&a, index, sub).unwrap() || v == DICT.read(&b, index, sub).unwrap(), "{index:#x}:{sub}: {v:02x?}");
    }
}

#[test]
fn a_power_cut_after_any_step_of_a_store_in_stages_keeps_the_old_set() {
    let mut flash = Flash::new();
    let mut img = boot(&mut flash, 2);
    DICT.write(&mut img, 0x2000, 0, &1111u32.to_le_bytes()).unwrap();
    save(&DICT, &img, 2, &mut flash, Scope::All).unwrap();
    DICT.write(&mut img, 0x2000, 0, &2222u32.to_le_bytes()).unwrap();
    let base = flash.regions;
    for cut in 0.. {
        // Run `cut` steps of 2 bytes, then lose the job (the power is gone).
        let mut f = Flash { regions: base, budget: None };
        let mut job = Job::save(Scope::All, None);
        let done = (0..=cut).any(|_| job.step_with(&DICT, &img, 2, &mut f, 2).is_some());
        let loaded = boot(&mut f, 2);
        let want: u32 = if done { 2222 } else { 1111 };
        assert_eq!(DICT.read(&loaded, 0x2000, 0), Ok(&want.to_le_bytes()[..]), "after {cut} steps");
        if done {
            assert!(cut > 4, "{cut} steps");
            break;
        }
    }
}

const LONGEST_ENTRIES: [Entry; 3] = [
    Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 0),
    Entry::new(0x2001, 0, DataType::OctetString, RW, 200, 2),
    Entry::new(0x2002, 0, DataType::Unsigned32, RW, 4, 202),
];
/// A dictionary with a value longer than a step's piece ([`super::PIECE`]).
static LONGEST: Dictionary = Dictionary {
    entries: &LONGEST_ENTRIES,
    defaults: crate::od::Defaults::dense(&[0; 206]),
    comm_len: 2,
    stored_len: 206,
    node_id_relative: &[],
    layout_id: crate::od::layout_id(&LONGEST_ENTRIES),
    ..DICT
};

#[test]
fn a_value_longer_than_a_piece_is_stored_whole_in_one_step_of_its_own() {
    // Two images: the value changes between any two steps.
    let mut a = [0u8; 206];
    let mut b = [0u8; 206];
    LONGEST.write(&mut a, 0x1017, 0, &1u16.to_le_bytes()).unwrap();
    LONGEST.write(&mut a, 0x2001, 0, &[0x11; 200]).unwrap();
    LONGEST.write(&mut a, 0x2002, 0, &1u32.to_le_bytes()).unwrap();
    LONGEST.write(&mut b, 0x1017, 0, &2u16.to_le_bytes()).unwrap();
    LONGEST.write(&mut b, 0x2001, 0, &[0x22; 200]).unwrap();
    LONGEST.write(&mut b, 0x2002, 0, &2u32.to_le_bytes()).unwrap();
    for budget in [STAGE, 3] {
        let mut flash = Flash::new();
        let mut job = Job::save(Scope::All, None);
        let mut steps = 0;
        let mut img = a;
        let result = loop {
            if let Some(result) = job.step_with(&LONGEST, &img, 1, &mut flash, budget) {
                break result;
            }
            steps += 1;
            img = if steps % 2 == 0 { a } else { b };
        };
        assert_eq!(result, Ok(()));
        // Find, erase, then 0x1017, 0x2001 alone and 0x2002 (three write steps).
        assert_eq!(steps, 4, "budget {budget}");
        let mut loaded = [0u8; 206];
        for part in [Part::Application, Part::Communication] {
            assert!(load(&LONGEST, &mut loaded, 1, &mut flash, part));
        }
        let value = LONGEST.read(&loaded, 0x2001, 0).unwrap();
        // The image of the step that wrote each value: the 0x2001 step's was b (after two steps).
        assert_eq!(LONGEST.read(&loaded, 0x1017, 0), Ok(&1u16.to_le_bytes()[..]), "budget {budget}");
        assert_eq!(value, [0x22; 200], "budget {budget}");
        assert_eq!(LONGEST.read(&loaded, 0x2002, 0), Ok(&1u32.to_le_bytes()[..]), "budget {budget}");
    }
    // A power cut at any write leaves the old set or the new one.
    let mut base = Flash::new();
    save(&LONGEST, &a, 1, &mut base, Scope::All).unwrap();
    for cut in 1..8 {
        let mut f = Flash { regions: base.regions, budget: Some(cut) };
        let done = save(&LONGEST, &b, 1, &mut f, Scope::All).is_ok();
        f.budget = None;
        let mut loaded = [0u8; 206];
        for part in [Part::Application, Part::Communication] {
            assert!(load(&LONGEST, &mut loaded, 1, &mut f, part));
        }
        assert_eq!(loaded, if done { b } else { a }, "cut {cut}");
    }
}

/// A set is the stored prefix alone: a dictionary whose prefix is shorter
/// (0x1001 read-only at its end) writes a shorter set, a change of 0x1001
/// leaves the set's bytes as they were, and a set of the other prefix length
/// is refused, even with the same entries (and so the same layout id).
#[test]
fn a_set_holds_the_stored_prefix_alone() {
    static ENTRIES_RO_LAST: [Entry; 2] =
        [Entry::new(0x1001, 0, DataType::Unsigned8, Attr::READ, 1, 2), Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 0)];
    static PREFIX: Dictionary = Dictionary {
        entries: &ENTRIES_RO_LAST,
        defaults: crate::od::Defaults::dense(&[0xE8, 0x03, 0]),
        comm_len: 2,
        stored_len: 2,
        comm_rest: 1,
        node_id_relative: &[],
        layout_id: crate::od::layout_id(&ENTRIES_RO_LAST),
        ..DICT
    };
    let (mut a, mut b) = (Flash::new(), Flash::new());
    save(&PREFIX, &[0x10, 0, 1], 1, &mut a, Scope::All).unwrap();
    save(&PREFIX, &[0x10, 0, 2], 1, &mut b, Scope::All).unwrap();
    assert_eq!(a.regions, b.regions, "the read-only value is not in the set");
    assert_eq!(&a.regions[0][16..18], &2u16.to_le_bytes(), "the header's length is the prefix");
    assert_eq!(a.regions[0][HEADER + 2], 0xFF, "nothing written after the prefix");
    assert_eq!(stored_value(&PREFIX, &mut a, 1, 0x1001, 0, &mut [0]), None);
    assert_eq!(stored_value(&PREFIX, &mut a, 1, 0x1017, 0, &mut [0; 2]), Some(2));
    let mut img = [0xE8, 0x03, 7];
    assert!(load(&PREFIX, &mut img, 1, &mut a, Part::Communication));
    assert_eq!(img, [0x10, 0, 0], "the reset takes 0x1017 from the set and 0x1001's default");
    // Reset communication restores both runs of the communication area.
    PREFIX.reset_communication(&mut img, 1);
    assert_eq!(img, [0xE8, 0x03, 0]);
    static LONGER: Dictionary =
        Dictionary { defaults: crate::od::Defaults::dense(&[0xE8, 0x03, 0]), stored_len: 3, comm_len: 3, comm_rest: 0, ..PREFIX };
    assert_eq!(LONGER.layout_id, PREFIX.layout_id);
    assert_eq!(newest(&LONGER, &mut a), None, "a set of another prefix is refused");
}

#[test]
fn storing_objects_no_set_holds_is_an_error_not_nothing() {
    let mut flash = Flash::new();
    let img = boot(&mut flash, 1);
    // No stored set holds a value of 0x1018 (this dictionary has none).
    assert_eq!(save_objects(&DICT, &img, 1, &mut flash, 0x1018, 0x1018), Err(StoreError::NotStored));
}

/// A set of another layout (the firmware before an update) is reported as
/// refused until a set of this layout is written; a header a power cut left
/// half written is not a set, and a set of this layout in the other region
/// is what the node loads, so nothing is lost then.
#[test]
fn a_complete_set_of_another_layout_alone_is_reported_as_refused() {
    static OLD: Dictionary = Dictionary { layout_id: DICT.layout_id ^ 1, ..DICT };
    let mut flash = Flash::new();
    assert!(!refused(&DICT, &mut flash), "nothing stored");
    let img = boot(&mut flash, 1);
    save(&OLD, &img, 1, &mut flash, Scope::All).unwrap();
    assert!(newest(&DICT, &mut flash).is_none());
    assert!(refused(&DICT, &mut flash));
    assert!(!refused(&OLD, &mut flash), "its own layout");
    // The payload broken: not a complete set.
    let mut broken = Flash { regions: flash.regions, budget: None };
    broken.regions[0][HEADER] ^= 1;
    assert!(!refused(&DICT, &mut broken));
    // A store of the old layout cut at any step leaves a set of it or none.
    for cut in 1..8 {
        let mut f = Flash { regions: [[0xFF; REGION]; 2], budget: Some(cut) };
        let done = save(&OLD, &img, 1, &mut f, Scope::All).is_ok();
        f.budget = None;
        assert_eq!(refused(&DICT, &mut f), done, "cut {cut}");
    }
    // A save of this layout ends it, though an old set is still in the other region.
    save(&OLD, &img, 1, &mut flash, Scope::All).unwrap();
    assert!(refused(&DICT, &mut flash), "two old sets");
    save(&DICT, &img, 1, &mut flash, Scope::Communication).unwrap();
    assert!(flash.regions.iter().any(|r| r[8..12] == OLD.layout_id.to_le_bytes()));
    assert!(!refused(&DICT, &mut flash));
    // So does a restore of the defaults.
    let mut flash = Flash::new();
    save(&OLD, &img, 1, &mut flash, Scope::All).unwrap();
    restore_defaults(&DICT, &img, 1, &mut flash, Scope::All).unwrap();
    assert!(!refused(&DICT, &mut flash));
}

const GAPPY_ENTRIES: [Entry; 2] =
    [Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 0), Entry::new(0x2002, 0, DataType::Unsigned32, RW, 4, 140)];
/// A hand-built dictionary whose stored prefix has bytes no value holds: a
/// gap longer than a step's piece between its values, and one after the
/// last (od-gen lays the values out back to back; `Dictionary`'s fields are
/// public).
static GAPPY: Dictionary = Dictionary {
    entries: &GAPPY_ENTRIES,
    defaults: crate::od::Defaults::dense(&[0; 150]),
    comm_len: 2,
    stored_len: 150,
    node_id_relative: &[],
    layout_id: crate::od::layout_id(&GAPPY_ENTRIES),
    ..DICT
};

#[test]
fn a_stored_prefix_with_gaps_is_stored_whole_and_loads() {
    let mut img = [0u8; 150];
    GAPPY.write(&mut img, 0x1017, 0, &7u16.to_le_bytes()).unwrap();
    GAPPY.write(&mut img, 0x2002, 0, &0x1234_5678u32.to_le_bytes()).unwrap();
    for budget in [STAGE, 3] {
        let mut flash = Flash::new();
        let mut job = Job::save(Scope::All, None);
        let result = loop {
            if let Some(result) = job.step_with(&GAPPY, &img, 1, &mut flash, budget) {
                break result;
            }
        };
        assert_eq!(result, Ok(()), "budget {budget}");
        let mut loaded = [0u8; 150];
        for part in [Part::Application, Part::Communication] {
            assert!(load(&GAPPY, &mut loaded, 1, &mut flash, part), "budget {budget}");
        }
        assert_eq!(GAPPY.read(&loaded, 0x1017, 0), Ok(&7u16.to_le_bytes()[..]), "budget {budget}");
        assert_eq!(GAPPY.read(&loaded, 0x2002, 0), Ok(&0x1234_5678u32.to_le_bytes()[..]), "budget {budget}");
    }
}
