//! The `agile` image for the STM32F103C8 board; see docs/firmware.md.
//! 250 kbit/s: factory setting of parameter 385 (docs/devices/agile.md).
#![no_std]
#![no_main]

canopen_firmware::image!(stm32f103, agile, bit_rate_kbps = 250);
