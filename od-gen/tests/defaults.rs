//! The generated defaults keep only the runs that are not zero: read back,
//! they must be the EDS defaults byte for byte, at the image's edges too.

use od_gen::runtime::Tables;
use od_gen::{Options, load};

/// Manufacturer values, all writable, so they lie in index order in the
/// stored prefix, which is the whole RAM image here: a 1-byte run first, a
/// 2-byte gap bridged, a 9-byte gap split, a 1-byte run alone, and a value
/// whose last byte, the image's last, is not zero (a 1-byte run too).
const EDS: &str = "\
[DeviceInfo]
VendorName=t
ProductName=t
[MandatoryObjects]
SupportedObjects=1
1=0x1000
[ManufacturerObjects]
SupportedObjects=6
1=0x2000
2=0x2001
3=0x2002
4=0x2003
5=0x2004
6=0x2005
[1000]
ParameterName=Device type
ObjectType=0x7
DataType=0x0007
AccessType=const
DefaultValue=0
[2000]
ParameterName=First
ObjectType=0x7
DataType=0x0005
AccessType=rw
DefaultValue=0x11
[2001]
ParameterName=Bridged gap
ObjectType=0x7
DataType=0x0006
AccessType=rw
DefaultValue=0
[2002]
ParameterName=After the gap
ObjectType=0x7
DataType=0x0006
AccessType=rw
DefaultValue=0x0022
[2003]
ParameterName=Split gap
ObjectType=0x7
DataType=0x001B
AccessType=rw
DefaultValue=0
[2004]
ParameterName=Alone
ObjectType=0x7
DataType=0x0005
AccessType=rw
DefaultValue=0x33
[2005]
ParameterName=Last
ObjectType=0x7
DataType=0x001B
AccessType=rw
DefaultValue=0x4400000000000000
";

#[test]
fn the_runs_read_back_as_the_eds_defaults() {
    let (eds, diags) = load("defaults.eds", EDS.as_bytes(), Options { strict: false });
    assert!(!diags.has_errors(), "{diags}");
    let t = Tables::new(&eds).expect("laid out");
    // The EDS defaults, little-endian, in index order.
    let expected = [[0x11].as_slice(), &[0; 2], &[0x22, 0x00], &[0; 8], &[0x33], &[0, 0, 0, 0, 0, 0, 0, 0x44]].concat();
    assert_eq!(t.defaults, expected, "the layout this test relies on");
    let dict = t.leak();
    assert_eq!(dict.defaults.runs, &[(0, 4), (9, 1), (7, 1)], "(zeros before, length): the 9-byte gap splits, the 2-byte one does not");
    assert_eq!(dict.defaults.bytes.len(), 6);
    let mut whole = vec![0xAA; dict.defaults.len];
    dict.defaults.read(0, &mut whole);
    assert_eq!(whole, expected);
    // Every window, as the resets and the store read them: part by part, value by value.
    for start in 0..expected.len() {
        for end in start..=expected.len() {
            let mut part = vec![0xAA; end - start];
            dict.defaults.read(start, &mut part);
            assert_eq!(part, expected[start..end], "{start}..{end}");
        }
    }
}

#[test]
fn runs_of_no_bytes_span_long_gaps_and_the_dense_form_reads_back() {
    let mut image = vec![0; 300];
    image.extend([7, 0, 0, 0, 9]);
    let d = canopen_core::od::Defaults { len: image.len(), runs: &[(255, 0), (45, 1), (3, 1)], bytes: &[7, 9] };
    let mut read = vec![0xAA; image.len()];
    d.read(0, &mut read);
    assert_eq!(read, image);
    let dense: Vec<u8> = (0..=255).chain(0..=255).map(|b: u16| b as u8 | 1).collect();
    let d = canopen_core::od::Defaults::dense(dense.clone().leak());
    let mut read = vec![0xAA; 512];
    d.read(0, &mut read);
    assert_eq!(read, dense);
    let mut tail = [0xAA; 3];
    d.read(510, &mut tail);
    assert_eq!(tail, [dense[510], dense[511], 0], "past the image: zero");
}
