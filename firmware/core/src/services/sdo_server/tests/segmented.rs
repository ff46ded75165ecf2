//! Segmented upload and download with the toggle bit (CiA 301 §7.2.4.3.4–8).

use super::*;

// ---------------------------------------------------------------------------
// Segmented upload
// ---------------------------------------------------------------------------

#[test]
fn segmented_upload_of_a_120_byte_visible_string() {
    // CCT 2.16: 120 bytes = 17 segments of 7 and one of 1.
    let mut t = Sdo::new();
    t.x(ms(0), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    for (i, chunk) in LONG.chunks(7).enumerate() {
        let toggle = (i % 2) as u8;
        t.rx_bytes(ms(1 + i as u32), &[0x60 | toggle << 4, 0, 0, 0, 0, 0, 0, 0]);
        let last = i == 17;
        let b0 = toggle << 4 | ((7 - chunk.len() as u8) << 1) | u8::from(last);
        t.tx_bytes(&frame(b0, chunk));
    }
    // The first and last exchanges, spelt out.
    assert_eq!(&LONG[..7], b"ABCDEFG");
    assert_eq!(show(&frame(0x1D, &LONG[119..])), "1D 50 00 00 00 00 00 00");
    t.done(ms(18));
}

#[test]
fn segmented_upload_of_an_octet_string_and_an_empty_string() {
    let mut t = Sdo::new();
    t.x(ms(0), "40 11 20 00 00 00 00 00", "41 11 20 00 0A 00 00 00");
    t.x(ms(1), "60 00 00 00 00 00 00 00", "00 00 01 02 03 04 05 06");
    t.x(ms(2), "70 00 00 00 00 00 00 00", "19 07 08 09 00 00 00 00"); // t = 1, n = 4, c = 1
    // An empty VISIBLE_STRING cannot go expedited: size 0, then one segment with n = 7.
    t.image[22] = 0;
    t.x(ms(3), "40 10 20 00 00 00 00 00", "41 10 20 00 00 00 00 00");
    t.x(ms(4), "60 00 00 00 00 00 00 00", "0F 00 00 00 00 00 00 00");
    t.done(ms(4));
}

#[test]
fn segmented_upload_with_wrong_toggle_bit() {
    // CCT 2.17: the first segment request must have t = 0.
    let mut t = Sdo::new();
    t.x(ms(0), "40 08 10 00 00 00 00 00", "41 08 10 00 06 00 00 00");
    t.x(ms(1), "70 00 00 00 00 00 00 00", "80 08 10 00 00 00 03 05");
    t.done(ms(1));
    // And mid-transfer: t repeated.
    t.x(ms(2), "40 10 20 00 00 00 00 00", "41 10 20 00 78 00 00 00");
    t.x(ms(3), "60 00 00 00 00 00 00 00", "00 41 42 43 44 45 46 47");
    t.x(ms(4), "60 00 00 00 00 00 00 00", "80 10 20 00 00 00 03 05");
    t.done(ms(4));
}

// ---------------------------------------------------------------------------
// Segmented download
// ---------------------------------------------------------------------------

#[test]
fn segmented_download_with_size() {
    let mut t = Sdo::new();
    t.x(ms(0), "21 05 20 00 08 00 00 00", "60 05 20 00 00 00 00 00");
    t.x(ms(1), "00 01 02 03 04 05 06 07", "20 00 00 00 00 00 00 00");
    t.x(ms(2), "1D 08 00 00 00 00 00 00", "30 00 00 00 00 00 00 00"); // t = 1, n = 6, c = 1
    // CCT 2.15: 0x1017 segmented.
    t.x(ms(3), "21 17 10 00 02 00 00 00", "60 17 10 00 00 00 00 00");
    t.x(ms(4), "0B D0 07 00 00 00 00 00", "20 00 00 00 00 00 00 00");
    t.done(ms(4));
    assert_eq!(t.value(0x2005, 0), [1, 2, 3, 4, 5, 6, 7, 8]);
    assert_eq!(t.value(0x1017, 0), [0xD0, 0x07]);
}

#[test]
fn segmented_download_of_120_bytes_without_size_and_of_nothing() {
    let mut t = Sdo::new();
    let text = long(b'a');
    t.x(ms(0), "20 10 20 00 00 00 00 00", "60 10 20 00 00 00 00 00");
    for (i, chunk) in text.chunks(7).enumerate() {
        let toggle = (i % 2) as u8;
        let b0 = toggle << 4 | ((7 - chunk.len() as u8) << 1) | u8::from(i == 17);
        t.rx_bytes(ms(1 + i as u32), &frame(b0, chunk));
        t.tx_bytes(&[0x20 | toggle << 4, 0, 0, 0, 0, 0, 0, 0]);
    }
    t.done(ms(18));
    assert_eq!(t.value(0x2010, 0), text);
    // Size 0: one empty segment.
    t.x(ms(20), "21 10 20 00 00 00 00 00", "60 10 20 00 00 00 00 00");
    t.x(ms(21), "0F 00 00 00 00 00 00 00", "20 00 00 00 00 00 00 00");
    t.done(ms(21));
    assert_eq!(t.value(0x2010, 0), b"");
}

#[test]
fn segmented_download_errors() {
    let mut t = Sdo::new();
    // Wrong toggle on the second segment.
    t.x(ms(0), "21 05 20 00 08 00 00 00", "60 05 20 00 00 00 00 00");
    t.x(ms(1), "00 01 02 03 04 05 06 07", "20 00 00 00 00 00 00 00");
    t.x(ms(2), "0D 08 00 00 00 00 00 00", "80 05 20 00 00 00 03 05");
    // Fewer bytes than indicated.
    t.x(ms(3), "21 05 20 00 08 00 00 00", "60 05 20 00 00 00 00 00");
    t.x(ms(4), "01 01 02 03 04 05 06 07", "80 05 20 00 13 00 07 06");
    // More bytes than indicated.
    t.x(ms(5), "21 11 20 00 03 00 00 00", "60 11 20 00 00 00 00 00");
    t.x(ms(6), "03 01 02 03 04 05 06 00", "80 11 20 00 12 00 07 06");
    // Indicated size too large for the entry, then too small for a fixed-size one.
    t.x(ms(7), "21 11 20 00 0B 00 00 00", "80 11 20 00 12 00 07 06");
    t.x(ms(8), "21 05 20 00 07 00 00 00", "80 05 20 00 13 00 07 06");
    // The complete value is refused by the entry's limits.
    t.x(ms(9), "21 00 20 00 02 00 00 00", "60 00 20 00 00 00 00 00");
    t.x(ms(10), "0B 00 80 00 00 00 00 00", "80 00 20 00 32 00 09 06");
    // A request of another transfer type in the middle.
    t.x(ms(11), "21 05 20 00 08 00 00 00", "60 05 20 00 00 00 00 00");
    t.x(ms(12), "60 00 00 00 00 00 00 00", "80 05 20 00 01 00 04 05");
    t.done(ms(12));
    assert_eq!(t.image, DEFAULTS);
}

#[test]
fn downloads_larger_than_the_buffer_run_out_of_memory() {
    let mut t = Test::<16>::new();
    t.x(ms(0), "21 10 20 00 11 00 00 00", "80 10 20 00 05 00 04 05"); // 17 bytes indicated
    t.x(ms(1), "20 10 20 00 00 00 00 00", "60 10 20 00 00 00 00 00"); // size not indicated
    t.x(ms(2), "00 61 62 63 64 65 66 67", "20 00 00 00 00 00 00 00");
    t.x(ms(3), "10 61 62 63 64 65 66 67", "30 00 00 00 00 00 00 00");
    t.x(ms(4), "09 61 62 63 00 00 00 00", "80 10 20 00 05 00 04 05"); // n = 4: 14 + 3 > 16
    t.x(ms(5), "C6 10 20 00 11 00 00 00", "80 10 20 00 05 00 04 05"); // block download, 17 bytes indicated
    t.done(ms(5));
    assert_eq!(t.image, DEFAULTS);
}
