//! The default SDO server's COB-IDs (0x1200:01/02) follow the node-id
//! (CiA 301, the pre-defined connection set), also where a tool wrote them
//! as plain numbers for the node-id it had.

use canopen_core::od::ObjectDictionary;
use od_gen::runtime::{RuntimeRam, Tables};
use od_gen::{Options, Severity, load};

/// A minimal device with the default SDO server as `sdo` gives it.
fn device(sdo: &str, commissioning: &str) -> String {
    format!(
        "[DeviceInfo]\nVendorName=V\nVendorNumber=1\nProductName=P\nProductNumber=1\nRevisionNumber=1\nOrderCode=O\nBaudRate_250=1\n\
         NrOfRXPDO=0\nNrOfTXPDO=0\n\n[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n\n[OptionalObjects]\nSupportedObjects=1\n1=0x1200\n\n\
         [1000]\nParameterName=Device Type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n\n\
         [1001]\nParameterName=Error Register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\n\n{sdo}{commissioning}"
    )
}

/// 0x1200 as CanFestival's objdictgen writes it (an excerpt of
/// `examples/DS401_Slave_Gui/DS401_Slave_Gui.eds` of ljessendk/CanFestival,
/// LGPL-2.1; `tests/eds-corpus/canfestival__DS401_Slave_Gui.eds`): the
/// COB-IDs of its node 64 in decimal.
const CANFESTIVAL_1200: &str = "[1200]\nParameterName=Server SDO Parameter\nObjectType=0x8\nSubNumber=3\n\n\
    [1200sub0]\nParameterName=Number of Entries\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=2\nPDOMapping=0\n\n\
    [1200sub1]\nParameterName=COB ID Client to Server (Receive SDO)\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=1600\nPDOMapping=0\n\n\
    [1200sub2]\nParameterName=COB ID Server to Client (Transmit SDO)\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=1472\nPDOMapping=0\n";

/// 0x1200:01 and :02 of the RAM image for `node`.
fn sdo_cob_ids(text: &str, file: &str, node: u8) -> (u32, u32) {
    let (eds, d) = load(file, text.as_bytes(), Options::default());
    assert!(!d.has_errors(), "{d}");
    let dict = Tables::new(&eds).expect("tables").leak();
    let ram = RuntimeRam::new(dict, node);
    let read = |sub| {
        let bytes = dict.read(ram.image(), 0x1200, sub).expect("0x1200 reads");
        u32::from_le_bytes(bytes.try_into().expect("UNSIGNED32"))
    };
    (read(1), read(2))
}

#[test]
fn absolute_default_sdo_cob_ids_follow_the_node_id_with_a_warning() {
    let text = device(CANFESTIVAL_1200, "");
    for node in [5, 64, 127] {
        assert_eq!(sdo_cob_ids(&text, "cf.eds", node), (0x600 + u32::from(node), 0x580 + u32::from(node)));
    }
    let (_, d) = load("cf.eds", text.as_bytes(), Options::default());
    let line = |key: &str| text.lines().position(|l| l == key).expect("key") + 1;
    assert!(
        d.mentions(Severity::Warning, line("DefaultValue=1600"), "0x1200:01 (client -> server) is 0x640, the COB-ID of node 64"),
        "{d}"
    );
    assert!(d.mentions(Severity::Warning, line("DefaultValue=1472"), "read as 0x580+$NODEID"), "{d}");
}

#[test]
fn a_dcf_of_that_node_id_says_nothing_and_other_values_stay() {
    // The DCF configures node 64: the values are that node's, no warning.
    let dcf = device(CANFESTIVAL_1200, "\n[DeviceComissioning]\nNodeID=64\n");
    let (_, d) = load("cf.dcf", dcf.as_bytes(), Options::default());
    assert!(!d.items.iter().any(|i| i.message.contains("0x1200")), "{d}");
    assert_eq!(sdo_cob_ids(&dcf, "cf.dcf", 3), (0x603, 0x583));
    // `$NODEID` values are already relative; a value that is no node's
    // pre-defined COB-ID is left as written.
    let relative = CANFESTIVAL_1200.replace("=1600", "=$NODEID+0x600").replace("=1472", "=0x580+$NODEID");
    assert_eq!(sdo_cob_ids(&device(&relative, ""), "rel.eds", 9), (0x609, 0x589));
    let other = CANFESTIVAL_1200.replace("=1600", "=0x6FF").replace("=1472", "=0x580");
    assert_eq!(sdo_cob_ids(&device(&other, ""), "other.eds", 9), (0x6FF, 0x580));
}
