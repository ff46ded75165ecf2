//! A CANopen device: the dictionary of `device.eds` with the rules of
//! `device.rs`, on the board the feature selects.
#![no_std]
#![no_main]

mod device;

#[cfg(feature = "stm32f103")]
canopen_firmware::image!(stm32f103, device = crate::device, bit_rate_kbps = 250);
#[cfg(all(feature = "qemu", not(feature = "stm32f103")))]
canopen_firmware::image!(qemu, device = crate::device);
