//! The five devices this firmware ships, each defined by its EDS.

pub mod agile;
pub mod bmaxx4400;
pub mod ec5000;
pub mod sendix;
mod sync_watch;
pub mod unitek_ds;

use canopen_core::od::Dictionary;
use canopen_core::storage::Storage;

/// What a host tool or board needs to pick a device by name.
#[derive(Debug)]
pub struct Device {
    /// The name used on command lines and in image names (`ec5000`).
    pub name: &'static str,
    /// What it is, in a few words.
    pub description: &'static str,
    /// Its dictionary.
    pub dictionary: &'static Dictionary,
    /// Node-id used when nothing is configured, as the manual says.
    pub default_node_id: u8,
    /// The node-id and bit rate (CiA 305 table index) the device's own
    /// stored parameters give at power-on, for a device that keeps them
    /// outside LSS (a configuration LSS stored still comes first); `None`:
    /// [`Device::default_node_id`] and the image's bit rate.
    pub startup: Option<Startup>,
}

/// Reads a device's start-up node-id and bit rate (CiA 305 table index,
/// `None`: the image's own) from its stored parameters.
pub type Startup = fn(&mut dyn Storage) -> (u8, Option<u8>);

/// Every device, in seed order.
pub static ALL: [Device; 5] = [ec5000::DEVICE, unitek_ds::DEVICE, sendix::DEVICE, bmaxx4400::DEVICE, agile::DEVICE];

/// The device called `name`.
pub fn by_name(name: &str) -> Option<&'static Device> {
    ALL.iter().find(|d| d.name == name)
}
