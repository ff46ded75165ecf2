//! The `ec5000` image for the QEMU board (lm3s6965evb); see docs/firmware.md.
#![no_std]
#![no_main]

canopen_firmware::image!(qemu, ec5000);
