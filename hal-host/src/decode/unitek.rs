//! UNITEK DS register-protocol frames for the live trace: requests on the
//! drive's RX id, replies on its TX id (firmware's `unitek_ds::wire`), each
//! register named by its object 0x2000 + REGID of the device's dictionary.

use super::{ObjectNames, format_value, hex_bytes};
use canopen_core::od::DataType;
use firmware::devices::unitek_ds::wire::{Period, Reply, Request, Value};

/// Identifiers of a UNITEK drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Ids {
    pub(super) rx: u16,
    pub(super) tx: u16,
}

/// `0x31 Speed set point`, or just the REGID.
fn register(names: Option<ObjectNames>, regid: u8) -> String {
    match names.and_then(|n| n.name(0x2000 + u16::from(regid), 0)) {
        Some(name) => format!("0x{regid:02X} {name}"),
        None => format!("0x{regid:02X}"),
    }
}

/// A value as the register's type reads it, widened or cut to its width as the drive does.
fn value(names: Option<ObjectNames>, regid: u8, v: Value) -> String {
    let t = names.and_then(|n| n.data_type(0x2000 + u16::from(regid), 0));
    let wide = match (v, t) {
        (Value::Bits16(v), Some(DataType::Integer32)) => i32::from(v as i16) as u32,
        (Value::Bits16(v), _) => u32::from(v),
        (Value::Bits32(v), _) => v,
    };
    let bytes = wide.to_le_bytes();
    match t {
        Some(DataType::Integer16 | DataType::Unsigned16) => format_value(t, bytes.get(..2).unwrap_or(&bytes)),
        Some(DataType::Integer32 | DataType::Unsigned32) => format_value(t, &bytes),
        _ => match v {
            Value::Bits16(_) => format_value(None, bytes.get(..2).unwrap_or(&bytes)),
            Value::Bits32(_) => format_value(None, &bytes),
        },
    }
}

/// The meaning of a frame on the drive's identifiers, if it is on one.
pub(super) fn decode(names: Option<ObjectNames>, ids: Ids, cob_id: u16, data: &[u8]) -> Option<String> {
    if cob_id == ids.rx {
        return Some(match Request::parse(data) {
            Ok(Request::Read { regid, period: Period::Once }) => format!("UNITEK read {}", register(names, regid)),
            Ok(Request::Read { regid, period: Period::EveryMs(ms) }) => format!("UNITEK read {} every {ms} ms", register(names, regid)),
            Ok(Request::Read { regid, period: Period::Stop }) => format!("UNITEK stop cyclic {}", register(names, regid)),
            Ok(Request::Write { regid, value: v }) => format!("UNITEK write {} = {}", register(names, regid), value(names, regid, v)),
            Err(_) => format!("UNITEK malformed request [{}]", hex_bytes(data)),
        });
    }
    if cob_id == ids.tx {
        return Some(match Reply::parse(data) {
            Ok(r) => {
                let v = if r.wide { Value::Bits32(r.value) } else { Value::Bits16(r.value as u16) };
                format!("UNITEK {} = {}", register(names, r.regid), value(names, r.regid, v))
            }
            Err(_) => format!("UNITEK malformed reply [{}]", hex_bytes(data)),
        });
    }
    None
}
