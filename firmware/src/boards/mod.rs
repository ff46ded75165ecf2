//! The boards an image runs on. A board moves frames between its CAN
//! controller (or SLCAN link) and the CANopen task (`app`), keeps time for
//! embassy, and provides a [`canopen_core::storage::Storage`]; it holds no
//! CANopen logic. This is the only place with
//! `unsafe` code (register access, interrupt set-up), each block with a
//! `// SAFETY:` comment.
//!
//! - [`qemu`]: lm3s6965evb under `qemu-system-arm` (feature `board-qemu`).
//! - [`stm32f103`]: STM32F103C8 with bxCAN (feature `board-stm32f103`).
//!
//! Each board exports the same items, which [`crate::image!`] uses:
//! `Config` (with a `DEFAULT`), `Storage<const REGION: usize>` (with an
//! `attach(StorageHandle)`), `StorageHandle` (what the storage gets at
//! start-up), `const fn unattached_storage()`,
//! `const fn check_link(image, region)` (stops an image's build whose
//! storage and program's flash disagree) and
//! `run(config, make_node, application) -> !`.

#[cfg(all(feature = "board-qemu", feature = "board-stm32f103"))]
compile_error!("enable one board feature per build: `board-qemu` or `board-stm32f103`");

pub mod qemu;
pub mod stm32f103;

// Every MCU build that links the firmware crate (the images, and
// `bench/size`'s node images) gets the small `memcpy` and 64-bit division.
#[cfg(any(test, target_os = "none"))]
mod div;
#[cfg(target_os = "none")]
mod mem;
#[cfg(all(target_os = "none", any(feature = "board-qemu", feature = "board-stm32f103")))]
mod stack;
#[cfg(all(target_os = "none", any(feature = "board-qemu", feature = "board-stm32f103")))]
mod systick;

/// Bytes of a storage region for a dictionary whose stored set is `image`
/// bytes (its `STORED_SIZE`, the prefix of the RAM image a set holds): the
/// set plus the store header (24 bytes, `services::store`),
/// rounded up to a flash half-word.
pub const fn region_size(image: usize) -> usize {
    (image + 24).next_multiple_of(2)
}

/// Defines an image's entry point: `canopen_firmware::image!(<board>, <device>)`
/// for a device of this crate ([`crate::devices`]), or
/// `canopen_firmware::image!(<board>, device = <path>)` for a device module
/// of your own crate, optionally followed by `key = value` settings of the
/// board's `Config` (`bit_rate_kbps = 250` on the STM32F103).
///
/// A device module holds what this crate's devices hold: `od` (the module
/// od-gen generated from its EDS), `App` (its [`canopen_core::node::Application`],
/// with a `const NEW`), `Node<S>` (`od::Node<App, S>`) and `DEVICE` (a
/// [`crate::devices::Device`]). The crate using the macro depends on
/// `cortex-m-rt` and `embassy-executor` itself (their attribute macros
/// name them); the rest it reaches through this crate.
///
/// The node lives in a `static` built at compile time (so it lies in `.bss`
/// and its size shows there); start-up hands its storage the board's
/// handle and powers it on where it lies. It runs the
/// device's dictionary with the device's own hooks (`device::App`). It starts with the
/// node-id the device's start-up hook reads from its stored parameters
/// (`Device::startup`), else the device's default one; a configuration LSS
/// stored overrides both (`Node::power_on`). The board hands the node to
/// its CANopen task; the image's application task runs
/// `app::run_application`, which reaches the node through requests.
#[macro_export]
macro_rules! image {
    ($board:ident, device = $device:path $(, $key:ident = $value:expr)* $(,)?) => {
        $crate::image!(@image $board, $device $(, $key = $value)*);
    };
    ($board:ident, $device:ident $(, $key:ident = $value:expr)* $(,)?) => {
        $crate::image!(@image $board, $crate::devices::$device $(, $key = $value)*);
    };
    (@image $board:ident, $device:path $(, $key:ident = $value:expr)*) => {
        #[::embassy_executor::task]
        async fn application() -> ! {
            $crate::app::run_application(&$crate::app::SHARED).await
        }

        #[::cortex_m_rt::entry]
        fn main() -> ! {
            use $device as device;
            const REGION: usize = $crate::boards::region_size(device::od::STORED_SIZE);
            // The storage's flash layout and the program's `memory.x` region
            // (build.rs sizes it per image) must agree.
            const { $crate::boards::$board::check_link(env!("CARGO_BIN_NAME"), REGION) };
            type Storage = $crate::boards::$board::Storage<REGION>;
            type Node = device::Node<Storage>;
            // Built at compile time, in `.bss` (canopen_core::node): no
            // node-sized value on the stack at start-up (docs/firmware.md, "Stack").
            static NODE: $crate::__private::ConstStaticCell<Node> = $crate::__private::ConstStaticCell::new(Node::unpowered(
                device::od::Ram::zeroed(),
                device::App::NEW,
                $crate::boards::$board::unattached_storage(),
            ));
            #[allow(clippy::needless_update)]
            let config = $crate::boards::$board::Config { $($key: $value,)* ..$crate::boards::$board::Config::DEFAULT };
            let make_node = |handle, now| {
                let node = NODE.take();
                node.storage_mut().attach(handle);
                let (node_id, bit_rate) = match device::DEVICE.startup {
                    Some(startup) => startup(node.storage_mut()),
                    None => (device::DEVICE.default_node_id, None),
                };
                node.power_on(node_id, now);
                $crate::app::Started { node, bit_rate }
            };
            $crate::boards::$board::run(config, make_node, application())
        }
    };
}
