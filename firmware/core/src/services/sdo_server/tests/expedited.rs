//! Expedited upload and download (CiA 301 §7.2.4.3.3, §7.2.4.3.6).

use super::*;

// ---------------------------------------------------------------------------
// Expedited upload
// ---------------------------------------------------------------------------

#[test]
fn expedited_upload_of_1_2_3_4_bytes() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 01 20 00 00 00 00 00", "4F 01 20 00 11 00 00 00");
    t.x(ms(1), "40 17 10 00 00 00 00 00", "4B 17 10 00 E8 03 00 00");
    t.x(ms(2), "40 03 20 00 00 00 00 00", "47 03 20 00 01 02 03 00");
    t.x(ms(3), "40 00 10 00 00 00 00 00", "43 00 10 00 92 01 02 00"); // CCT 2.1
    t.done(ms(3));
}

#[test]
fn upload_errors_name_the_cause() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 04 10 00 00 00 00 00", "80 04 10 00 00 00 02 06"); // CCT 2.6: no object
    t.x(ms(0), "40 00 10 01 00 00 00 00", "80 00 10 01 11 00 09 06"); // CCT 2.5: no sub-index
    t.x(ms(0), "40 02 20 00 00 00 00 00", "80 02 20 00 01 00 01 06"); // CCT 2.4: write-only
    t.x(ms(0), "40 12 20 00 00 00 00 00", "80 12 20 00 24 00 00 08"); // DOMAIN without application data
    t.done(ms(0));
}

// ---------------------------------------------------------------------------
// Expedited download
// ---------------------------------------------------------------------------

#[test]
fn expedited_download_of_1_2_3_4_bytes() {
    let mut t = Sdo::new();
    t.x(ms(0), "2F 01 20 00 55 00 00 00", "60 01 20 00 00 00 00 00");
    t.x(ms(0), "2B 17 10 00 D0 07 00 00", "60 17 10 00 00 00 00 00"); // CCT 2.2/7.101: heartbeat 2000 ms
    t.x(ms(0), "27 03 20 00 0A 0B 0C 00", "60 03 20 00 00 00 00 00");
    t.x(ms(0), "23 04 20 00 DD CC BB AA", "60 04 20 00 00 00 00 00");
    t.done(ms(0));
    assert_eq!(t.value(0x2001, 0), [0x55]);
    assert_eq!(t.value(0x1017, 0), [0xD0, 0x07]);
    assert_eq!(t.value(0x2003, 0), [0x0A, 0x0B, 0x0C]);
    assert_eq!(t.value(0x2004, 0), [0xDD, 0xCC, 0xBB, 0xAA]);
}

#[test]
fn expedited_download_without_size_takes_the_entry_length() {
    let mut t = Sdo::new();
    t.x(ms(0), "22 17 10 00 64 00 FF FF", "60 17 10 00 00 00 00 00"); // e = 1, s = 0: bytes 6-7 are padding
    t.x(ms(0), "22 01 20 00 07 FF FF FF", "60 01 20 00 00 00 00 00");
    t.x(ms(0), "22 11 20 00 01 02 03 04", "60 11 20 00 00 00 00 00"); // OCTET_STRING of 10: all 4 bytes
    t.x(ms(0), "22 05 20 00 01 02 03 04", "80 05 20 00 13 00 07 06"); // UNSIGNED64 cannot come in 4 bytes
    t.done(ms(0));
    assert_eq!(t.value(0x1017, 0), [0x64, 0x00]);
    assert_eq!(t.value(0x2001, 0), [0x07]);
    assert_eq!(t.value(0x2011, 0), [1, 2, 3, 4, 0, 0, 0, 0, 0, 0]);
}

#[test]
fn download_errors_name_the_cause() {
    let mut t = Sdo::new();
    let before = t.image;
    t.x(ms(0), "23 00 10 00 00 00 00 00", "80 00 10 00 02 00 01 06"); // CCT 2.3: read-only
    t.x(ms(0), "23 17 10 00 01 00 00 00", "80 17 10 00 12 00 07 06"); // CCT 2.8: u32 to u16
    t.x(ms(0), "2F 17 10 00 01 00 00 00", "80 17 10 00 13 00 07 06"); // CCT 2.9: u8 to u16
    t.x(ms(0), "2B 00 20 00 65 00 00 00", "80 00 20 00 31 00 09 06"); // CCT 2.10: 101 > 100
    t.x(ms(0), "2B 00 20 00 9B FF 00 00", "80 00 20 00 32 00 09 06"); // CCT 2.11: -101 < -100
    t.x(ms(0), "2F 12 20 00 01 00 00 00", "80 12 20 00 20 00 00 08"); // DOMAIN: no storage in the tables
    t.x(ms(0), "2F 20 20 07 01 00 00 00", "80 20 20 07 11 00 09 06");
    t.done(ms(0));
    assert_eq!(t.image, before);
}
