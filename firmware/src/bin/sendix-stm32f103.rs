//! The `sendix` image for the STM32F103C8 board; see docs/firmware.md.
//! 250 kbit/s: quick-start factory setting (docs/devices/sendix.md).
#![no_std]
#![no_main]

canopen_firmware::image!(stm32f103, sendix, bit_rate_kbps = 250);
