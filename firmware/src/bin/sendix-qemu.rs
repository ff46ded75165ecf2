//! The `sendix` image for the QEMU board (lm3s6965evb); see docs/firmware.md.
#![no_std]
#![no_main]

canopen_firmware::image!(qemu, sendix);
