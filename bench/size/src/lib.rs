//! What a board links of the stack, so `cargo xtask size` can weigh it.
//!
//! There is no board binary yet, so this crate plays one: for each
//! dictionary feature it has a node in a `static` (in `.bss`, as a firmware
//! would keep it) and the main loop a firmware runs — receive every frame,
//! [`Node::on_frame`], [`Node::process`], [`Node::transmit`] until the
//! controller is full, sleep until the deadline. The CAN controller, the
//! clock and the flash are the board's: here they are C callbacks in a
//! [`Board`] the optimizer cannot see through, so every service stays in.
//! The board receives every frame and programs no filter, so the `ds301`
//! and `ds301-lean` references are built without the node's acceptance
//! list (`Services::acceptance`, see `build.rs`), as CANopenNode's figure
//! leaves its filter set-up in the driver; the device images and `core`
//! keep it, as their boards' images do.
//!
//! The loops are kept by `#[used]` statics holding their addresses (no
//! `#[no_mangle]`: that is `unsafe_code`). `cargo xtask size` builds this
//! crate as a fat-LTO staticlib for thumbv7m, links it with `--gc-sections`
//! (the `#[used]` sections are the roots) and measures the result.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

use canopen_core::frame::CanFrame;
use canopen_core::storage::{Storage, StorageError};
use canopen_core::time::Instant;
// Linked into every image, the reference dictionaries' too: a board links
// the firmware crate, and with it the small `memcpy`/`memclr` that replace
// `compiler_builtins`' on the MCU (`firmware/src/boards/mem.rs`). Without a
// use of the crate, an image without a device would not link it at all.
use firmware as _;

/// A CAN frame as the board's controller driver hands it over.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct RawFrame {
    /// The identifier (11 or 29 bits).
    pub id: u32,
    /// Whether `id` is 29 bits.
    pub extended: bool,
    /// Whether this is a remote frame.
    pub rtr: bool,
    /// Data length code (0..=8).
    pub dlc: u8,
    /// Data bytes (the first `dlc`).
    pub data: [u8; 8],
}

impl RawFrame {
    fn to_frame(self) -> Option<CanFrame> {
        let len = usize::from(self.dlc);
        match (self.extended, self.rtr) {
            (false, true) => CanFrame::remote(u16::try_from(self.id).ok()?, len),
            (false, false) => CanFrame::standard(u16::try_from(self.id).ok()?, self.data.get(..len)?),
            (true, false) => CanFrame::extended(self.id, self.data.get(..len)?),
            (true, true) => None,
        }
    }

    fn from_frame(f: &CanFrame) -> Self {
        use embedded_can::Frame;
        let mut data = [0; 8];
        let d = f.data();
        if let Some(dst) = data.get_mut(..d.len()) {
            dst.copy_from_slice(d);
        }
        RawFrame { id: f.raw_id(), extended: f.is_extended_id(), rtr: f.is_remote_frame(), dlc: f.dlc() as u8, data }
    }
}

/// What the board provides: CAN controller, clock, flash, configuration.
#[repr(C)]
pub struct Board {
    /// Microseconds since power-on.
    pub now: extern "C" fn() -> u64,
    /// Takes the next received frame, if any.
    pub receive: extern "C" fn(&mut RawFrame) -> bool,
    /// Queues a frame in the controller; false when its mailboxes are full.
    pub send: extern "C" fn(&RawFrame) -> bool,
    /// Sleeps until the time given (µs) or the next interrupt.
    pub wait_until: extern "C" fn(u64),
    /// Reads `len` bytes of flash region `region` at `offset` into `buf`.
    pub flash_read: extern "C" fn(region: u8, offset: u32, buf: *mut u8, len: u32) -> bool,
    /// Erases a flash region.
    pub flash_erase: extern "C" fn(region: u8) -> bool,
    /// Programs `len` bytes from `data` at `offset` of `region`.
    pub flash_write: extern "C" fn(region: u8, offset: u32, data: *const u8, len: u32) -> bool,
    /// Size of each of the two flash regions.
    pub flash_region_size: u32,
    /// The node-id (from switches or LSS storage).
    pub node_id: u8,
}

/// [`Storage`] on the board's flash callbacks: unattached (`None`, zero
/// bits) in the node built at compile time, attached at power-on, as the
/// firmware images' storage is (`firmware::image!`).
pub struct BoardFlash(Option<&'static Board>);

fn status(ok: bool) -> Result<(), StorageError> {
    if ok { Ok(()) } else { Err(StorageError::Failed) }
}

fn range(offset: usize, len: usize) -> Result<(u32, u32), StorageError> {
    Ok((u32::try_from(offset).map_err(|_| StorageError::OutOfRange)?, u32::try_from(len).map_err(|_| StorageError::OutOfRange)?))
}

impl BoardFlash {
    fn board(&self) -> Result<&'static Board, StorageError> {
        self.0.ok_or(StorageError::Failed)
    }
}

impl Storage for BoardFlash {
    fn region_size(&self) -> usize {
        self.0.map_or(0, |b| b.flash_region_size as usize)
    }

    fn read(&mut self, region: u8, offset: usize, buf: &mut [u8]) -> Result<(), StorageError> {
        let (offset, len) = range(offset, buf.len())?;
        status((self.board()?.flash_read)(region, offset, buf.as_mut_ptr(), len))
    }

    fn erase(&mut self, region: u8) -> Result<(), StorageError> {
        status((self.board()?.flash_erase)(region))
    }

    fn write(&mut self, region: u8, offset: usize, data: &[u8]) -> Result<(), StorageError> {
        let (offset, len) = range(offset, data.len())?;
        status((self.board()?.flash_write)(region, offset, data.as_ptr(), len))
    }
}

/// A board's main loop, as `#[used]` keeps it.
#[repr(C)]
pub struct Entry {
    /// Runs the node forever.
    pub run: extern "C" fn(&'static Board) -> !,
}

/// One firmware per dictionary: the node static and its main loop.
macro_rules! firmware {
    ($feature:literal, $name:ident, $od:path) => {
        firmware!($feature, $name, $od, canopen_core::node::NoApplication, canopen_core::node::NoApplication);
    };
    ($feature:literal, $name:ident, $od:path, $app:ty, $new:expr) => {
        #[cfg(feature = $feature)]
        mod $name {
            use super::*;
            use static_cell::ConstStaticCell;
            use $od as od;

            type NodeT = od::Node<$app, BoardFlash>;

            /// Built at compile time and all zero bits, so in `.bss`, as
            /// the firmware images build theirs (`firmware::image!`).
            static NODE: ConstStaticCell<NodeT> = ConstStaticCell::new(NodeT::unpowered(od::Ram::zeroed(), $new, BoardFlash(None)));

            /// Power-on as the images do it (`firmware::image!`): the
            /// storage attached, then the node powered on where it lies.
            #[inline(never)]
            fn init(board: &'static Board) -> &'static mut NodeT {
                let now = Instant::from_micros((board.now)());
                let node = NODE.take();
                node.storage_mut().0 = Some(board);
                node.power_on(board.node_id, now);
                node
            }

            extern "C" fn run(board: &'static Board) -> ! {
                let node = init(board);
                let mut raw = RawFrame::default();
                loop {
                    let now = Instant::from_micros((board.now)());
                    while (board.receive)(&mut raw) {
                        if let Some(frame) = raw.to_frame() {
                            node.on_frame(now, &frame);
                        }
                    }
                    let next = node.process(now);
                    while let Some(frame) = node.transmit() {
                        if !(board.send)(&RawFrame::from_frame(&frame)) {
                            node.requeue(frame);
                            break;
                        }
                    }
                    (board.wait_until)(next.map_or(u64::MAX, Instant::as_micros));
                }
            }

            /// The root `--gc-sections` keeps.
            #[used]
            static ENTRY: Entry = Entry { run };
        }
    };
}

/// The interop test dictionary (`tests/eds/interop.eds`): every service, 4 + 4 PDOs.
#[cfg(feature = "interop")]
pub mod interop_od {
    include!(concat!(env!("OUT_DIR"), "/interop.rs"));
}

/// CANopenNode's CiA 301 profile (`tests/eds-corpus/canopennode__DS301_profile.eds`,
/// with 0x100C/0x100D for node guarding): 4 + 4 PDOs, 8 heartbeat consumers.
#[cfg(feature = "ds301")]
pub mod ds301_od {
    include!(concat!(env!("OUT_DIR"), "/ds301.rs"));
}

firmware!("interop", interop, crate::interop_od);
/// The same profile without node guarding, with CANopenNode's default
/// services: no block SDO, no guarding, no storage.
#[cfg(feature = "ds301-lean")]
pub mod ds301_lean_od {
    include!(concat!(env!("OUT_DIR"), "/ds301-lean.rs"));
}

firmware!("ds301", ds301, crate::ds301_od);
firmware!("ds301-lean", ds301_lean, crate::ds301_lean_od);
firmware!("ec5000", ec5000, firmware::devices::ec5000::od, firmware::devices::ec5000::App, firmware::devices::ec5000::App::NEW);
firmware!(
    "unitek-ds",
    unitek_ds,
    firmware::devices::unitek_ds::od,
    firmware::devices::unitek_ds::App,
    firmware::devices::unitek_ds::App::NEW
);
firmware!("sendix", sendix, firmware::devices::sendix::od, firmware::devices::sendix::App, firmware::devices::sendix::App::NEW);
firmware!(
    "bmaxx4400",
    bmaxx4400,
    firmware::devices::bmaxx4400::od,
    firmware::devices::bmaxx4400::App,
    firmware::devices::bmaxx4400::App::NEW
);
firmware!("agile", agile, firmware::devices::agile::od, firmware::devices::agile::App, firmware::devices::agile::App::NEW);

/// Panics end in a loop; the board's watchdog resets the node.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
