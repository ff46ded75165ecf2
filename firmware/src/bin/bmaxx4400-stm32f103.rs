//! The `bmaxx4400` image for the STM32F103C8 board; see docs/firmware.md.
//! 500 kbit/s: an assumption; the manual names no factory bit rate (one of its five, docs/devices/bmaxx4400.md).
#![no_std]
#![no_main]

canopen_firmware::image!(stm32f103, bmaxx4400, bit_rate_kbps = 500);
