//! The `ec5000` image for the STM32F103C8 board; see docs/firmware.md.
//! 250 kbit/s: factory setting of 0x4651; a watchdog, panic or HardFault
//! restart is EMCY 0x6010 (docs/devices/ec5000.md D53).
#![no_std]
#![no_main]

canopen_firmware::image!(stm32f103, ec5000, bit_rate_kbps = 250, restart_emcy = canopen_firmware::devices::ec5000::RESTART);
