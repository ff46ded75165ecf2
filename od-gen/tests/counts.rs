//! The node's slot counts in the generated module (`RPDO_COUNT`,
//! `TPDO_COUNT`, `HB_CONSUMER_COUNT`, `SDO_SERVERS`) reach the highest PDO,
//! consumer and SDO server the file has: the node keeps PDO n in slot n - 1
//! (0x1800 + n - 1), so a count of the records would leave out the highest
//! of a sparse set (TPDO1 and TPDO3: TPDO3 was never sent; checked against a
//! node built from the module, as vnode, whose runtime tables size by the
//! highest number, already did).

use od_gen::{Options, codegen, load};

/// A device with `objects` besides 0x1000/0x1001.
fn file(objects: &str) -> String {
    format!(
        "[DeviceInfo]\nVendorName=V\nVendorNumber=1\nProductName=P\nProductNumber=1\nRevisionNumber=1\nOrderCode=O\nBaudRate_250=1\n\
         NrOfRXPDO=0\nNrOfTXPDO=0\n\n\
         [1000]\nParameterName=Device Type\nObjectType=0x7\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n\n\
         [1001]\nParameterName=Error Register\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue=0\n\n{objects}"
    )
}

/// A record `index` with sub 0 and UNSIGNED32 entries (sub-index, value).
fn record(index: u16, subs: &[(u8, &str)]) -> String {
    let mut s = format!("[{index:04X}]\nParameterName=R{index:04X}\nObjectType=0x9\nSubNumber={}\n\n", subs.len() + 1);
    let top = subs.iter().map(|(sub, _)| *sub).max().unwrap_or(0);
    s += &format!(
        "[{index:04X}sub0]\nParameterName=Highest sub-index\nObjectType=0x7\nDataType=0x0005\nAccessType=ro\nDefaultValue={top}\n\n"
    );
    for (sub, value) in subs {
        s += &format!(
            "[{index:04X}sub{sub:X}]\nParameterName=E{sub}\nObjectType=0x7\nDataType=0x0007\nAccessType=rw\nDefaultValue={value}\n\n"
        );
    }
    s
}

fn constant(code: &str, name: &str) -> usize {
    let prefix = format!("pub const {name}: usize = ");
    code.lines()
        .find_map(|l| l.strip_prefix(&prefix))
        .and_then(|v| v.trim_end_matches(';').parse().ok())
        .unwrap_or_else(|| panic!("{name}"))
}

#[test]
fn sparse_pdos_consumers_and_sdo_servers_get_slots_up_to_the_highest() {
    let objects = [
        record(0x1200, &[(1, "$NODEID+0x600"), (2, "$NODEID+0x580")]),
        record(0x1202, &[(1, "0x80000000"), (2, "0x80000000")]),
        record(0x1400, &[(1, "$NODEID+0x200")]),
        record(0x1403, &[(1, "$NODEID+0x500")]),
        record(0x1800, &[(1, "$NODEID+0x180")]),
        record(0x1802, &[(1, "$NODEID+0x380")]),
        record(0x1016, &[(1, "0"), (3, "0")]),
    ]
    .concat();
    let text = file(&objects);
    let (eds, d) = load("sparse.eds", text.as_bytes(), Options::default());
    assert!(!d.has_errors(), "{d}");
    let code = codegen::generate(&eds, "sparse.eds").expect("generates");
    assert_eq!(constant(&code, "RPDO_COUNT"), 4);
    assert_eq!(constant(&code, "TPDO_COUNT"), 3);
    assert_eq!(constant(&code, "HB_CONSUMER_COUNT"), 3);
    assert_eq!(constant(&code, "SDO_SERVERS"), 3);
    // Dense sets are counted as before.
    let text = file(&[record(0x1800, &[(1, "$NODEID+0x180")]), record(0x1801, &[(1, "$NODEID+0x280")])].concat());
    let (eds, _) = load("dense.eds", text.as_bytes(), Options::default());
    let code = codegen::generate(&eds, "dense.eds").expect("generates");
    assert_eq!((constant(&code, "TPDO_COUNT"), constant(&code, "RPDO_COUNT"), constant(&code, "SDO_SERVERS")), (2, 0, 1));
}
