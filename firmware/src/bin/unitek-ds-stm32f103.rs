//! The `unitek-ds` image for the STM32F103C8 board; see docs/firmware.md.
//! 500 kbit/s: manual's default (docs/devices/unitek-ds.md).
#![no_std]
#![no_main]

canopen_firmware::image!(stm32f103, unitek_ds, bit_rate_kbps = 500);
