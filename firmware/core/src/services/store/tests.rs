//! Store/restore on a flash-like storage with a power cut at every step.

use super::*;
use crate::od::{DataType, DeviceInfo, Entry, NO_LIMITS};

const RW: Attr = Attr(Attr::READ.0 | Attr::WRITE.0);
const RW_N: Attr = Attr(RW.0 | Attr::NODE_ID.0);

static ENTRIES: [Entry; 5] = [
    Entry::new(0x1001, 0, DataType::Unsigned8, Attr::READ, 1, 0, NO_LIMITS),
    Entry::new(0x1017, 0, DataType::Unsigned16, RW, 2, 1, NO_LIMITS),
    Entry::new(0x1800, 1, DataType::Unsigned32, RW_N, 4, 3, NO_LIMITS),
    Entry::new(0x2000, 0, DataType::Unsigned32, RW, 4, 7, NO_LIMITS),
    Entry::new(0x6060, 0, DataType::Integer8, RW, 1, 11, NO_LIMITS),
];
static DEFAULTS: [u8; 12] = [0, 0, 0, 0x80, 0x01, 0, 0x40, 1, 0, 0, 0, 3];
static DICT: Dictionary = Dictionary {
    entries: &ENTRIES,
    limits: &[],
    rom: &[],
    defaults: &DEFAULTS,
    comm_len: 7,
    node_id_relative: &[2],
    device: DeviceInfo {
        baud_rates: 0,
        lss_supported: false,
        granularity: 8,
        simple_boot_up_slave: false,
        dynamic_channels: false,
        group_messaging: false,
    },
};

/// NOR-flash-like memory whose power can be cut after `budget` steps.
struct Flash {
    regions: [[u8; 64]; 2],
    budget: Option<usize>,
}

impl Flash {
    fn new() -> Self {
        Flash { regions: [[0xFF; 64]; 2], budget: None }
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
        64
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
    assert!(steps >= 4);
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
    assert!(newest(&mut flash, &DICT).is_none());
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
    assert_eq!(load_lss(&DICT, &mut flash), None);
    DICT.write(&mut img, 0x1017, 0, &300u16.to_le_bytes()).unwrap();
    save(&DICT, &img, 127, &mut flash, Scope::All).unwrap();
    save_lss(&DICT, &img, 127, &mut flash, 0x20, 3).unwrap();
    assert_eq!(load_lss(&DICT, &mut flash), Some((0x20, 3)));
    // The parameters stored before are still there, and a later save keeps the LSS part.
    let img = boot(&mut flash, 0x20);
    assert_eq!(DICT.read(&img, 0x1017, 0), Ok(&300u16.to_le_bytes()[..]));
    save(&DICT, &img, 0x20, &mut flash, Scope::Communication).unwrap();
    assert_eq!(load_lss(&DICT, &mut flash), Some((0x20, 3)));
    // A cut at any step of the next LSS store leaves (0x20, 3) or (0x21, 4).
    let base = flash.regions;
    for cut in 1..12 {
        let mut f = Flash { regions: base, budget: Some(cut) };
        let _ = save_lss(&DICT, &img, 0x20, &mut f, 0x21, 4);
        f.budget = None;
        let got = load_lss(&DICT, &mut f);
        assert!(got == Some((0x20, 3)) || got == Some((0x21, 4)), "cut {cut}: {got:?}");
    }
}
