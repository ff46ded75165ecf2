//! What a CAN frame means in CANopen terms, as one line of text for a live
//! trace. CiA 301 v4.2 §7.3.5 (pre-defined connection set: which COB-ID is
//! which service), §7.2.8.3 (NMT, heartbeat), §7.2.4 (SDO), §7.2.7 (EMCY),
//! §7.2.2 (PDO); abort codes table 22, EMCY codes table 21.
//!
//! The COB-ID tells the service. Object names and data types come from a
//! generated dictionary ([`ObjectNames`]); without one, objects are shown as
//! `0xIIII:SS` and values as raw bytes. PDOs are decoded along the mappings
//! given with [`Decoder::add_pdo`]. The [`Decoder`] keeps one piece of state:
//! the object of each node's SDO transfer, so that segments can be named and
//! a segmented value is shown whole with its last segment.
//!
//! The formats are the core's [`canopen_core::wire`] parsers; nothing here
//! panics on any frame.

#[cfg(test)]
mod tests;
mod unitek;

use crate::master::pdo::{self, MappingEntry};
use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::od::{DataType, Dictionary, Kind, Number};
use canopen_core::wire::emcy::{Emcy, EmcyCode};
use canopen_core::wire::nmt::{NmtCommand, NmtRequest, NmtStateCode};
use canopen_core::wire::sdo::{InitiateData, SdoRequest, SdoResponse};
use embedded_can::Frame;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The 29-bit identifier of the QEMU board's exit frame (docs/firmware.md).
pub const EXIT_ID: u32 = 0x1FFF_FFFF;

/// Names and data types of a device's objects: its generated `DICTIONARY`
/// and the parallel `NAMES` table (`ParameterName` of each entry).
#[derive(Clone, Copy, Debug)]
pub struct ObjectNames {
    dictionary: &'static Dictionary,
    names: &'static [&'static str],
}

impl ObjectNames {
    /// Pairs a dictionary with its names (`od::DICTIONARY`, `&od::NAMES`).
    pub fn new(dictionary: &'static Dictionary, names: &'static [&'static str]) -> Self {
        ObjectNames { dictionary, names }
    }

    fn position(&self, index: u16, sub: u8) -> Option<usize> {
        let key = (u32::from(index) << 8) | u32::from(sub);
        self.dictionary.entries.binary_search_by_key(&key, |e| e.key()).ok()
    }

    /// The `ParameterName` of (index, sub).
    pub fn name(&self, index: u16, sub: u8) -> Option<&'static str> {
        self.position(index, sub).and_then(|p| self.names.get(p).copied())
    }

    /// The data type of (index, sub).
    pub fn data_type(&self, index: u16, sub: u8) -> Option<DataType> {
        self.position(index, sub).and_then(|p| self.dictionary.entries.get(p)).map(|e| e.data_type)
    }
}

/// The CiA 301 text of an abort code.
pub fn abort_text(code: AbortCode) -> &'static str {
    use AbortCode::*;
    match code {
        ToggleBit => "Toggle bit not alternated",
        Timeout => "SDO protocol timed out",
        InvalidCommand => "Client/server command specifier not valid or unknown",
        InvalidBlockSize => "Invalid block size",
        InvalidSequence => "Invalid sequence number",
        CrcError => "CRC error",
        OutOfMemory => "Out of memory",
        UnsupportedAccess => "Unsupported access to an object",
        WriteOnly => "Attempt to read a write only object",
        ReadOnly => "Attempt to write a read only object",
        NoObject => "Object does not exist in the object dictionary",
        NotMappable => "Object cannot be mapped to the PDO",
        PdoTooLong => "The number and length of the objects to be mapped would exceed PDO length",
        ParameterIncompatible => "General parameter incompatibility reason",
        InternalIncompatible => "General internal incompatibility in the device",
        Hardware => "Access failed due to a hardware error",
        LengthMismatch => "Data type does not match, length of service parameter does not match",
        LengthTooHigh => "Data type does not match, length of service parameter too high",
        LengthTooLow => "Data type does not match, length of service parameter too low",
        NoSubIndex => "Sub-index does not exist",
        InvalidValue => "Invalid value for parameter",
        ValueTooHigh => "Value of parameter written too high",
        ValueTooLow => "Value of parameter written too low",
        MaxBelowMin => "Maximum value is less than minimum value",
        NoResource => "Resource not available: SDO connection",
        General => "General error",
        CannotStore => "Data cannot be transferred or stored to the application",
        LocalControl => "Data cannot be transferred or stored to the application because of local control",
        DeviceState => "Data cannot be transferred or stored to the application because of the present device state",
        NoDictionary => "Object dictionary dynamic generation fails or no object dictionary is present",
        NoData => "No data available",
    }
}

/// The CiA 301 text of an EMCY error code: the exact code where the
/// communication services define it, else its class (the high byte or nibble).
pub fn emcy_text(code: u16) -> &'static str {
    match code {
        0x0000 => "Error reset or no error",
        0x8110 => "CAN overrun (objects lost)",
        0x8120 => "CAN in error passive mode",
        0x8130 => "Life guard error or heartbeat error",
        0x8140 => "Recovered from bus off",
        0x8150 => "CAN-ID collision",
        0x8210 => "PDO not processed due to length error",
        0x8220 => "PDO length exceeded",
        0x8230 => "DAM MPDO not processed, destination object not available",
        0x8240 => "Unexpected SYNC data length",
        0x8250 => "RPDO timeout",
        _ => match code >> 8 {
            0x10 => "Generic error",
            0x20..=0x2F => "Current",
            0x30..=0x3F => "Voltage",
            0x40..=0x4F => "Temperature",
            0x50 => "Device hardware",
            0x60..=0x6F => "Device software",
            0x70 => "Additional modules",
            0x80 => "Monitoring",
            0x81 => "Communication",
            0x82 => "Protocol error",
            0x90 => "External error",
            0xF0 => "Additional functions",
            0xFF => "Device specific",
            _ => "Unknown error code",
        },
    }
}

fn nmt_command_text(command: NmtCommand) -> &'static str {
    match command {
        NmtCommand::Start => "Start remote node",
        NmtCommand::Stop => "Stop remote node",
        NmtCommand::EnterPreOperational => "Enter pre-operational",
        NmtCommand::ResetNode => "Reset node",
        NmtCommand::ResetCommunication => "Reset communication",
    }
}

/// The name CiA 301 gives an NMT state.
pub fn nmt_state_text(state: NmtStateCode) -> &'static str {
    match state {
        NmtStateCode::BootUp => "Boot-up",
        NmtStateCode::Stopped => "Stopped",
        NmtStateCode::Operational => "Operational",
        NmtStateCode::PreOperational => "Pre-operational",
    }
}

fn hex_bytes(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

/// A value as its data type reads: unsigned as hex with the decimal value,
/// signed and real in decimal, strings quoted; raw bytes without a type.
pub fn format_value(data_type: Option<DataType>, bytes: &[u8]) -> String {
    let Some(t) = data_type else { return format!("[{}]", hex_bytes(bytes)) };
    match (t, Number::decode(t, bytes)) {
        (DataType::Boolean, Some(Number::Unsigned(v))) => (v != 0).to_string(),
        (_, Some(Number::Unsigned(v))) => format!("0x{v:0width$X} ({v})", width = 2 * bytes.len()),
        (_, Some(Number::Signed(v))) => v.to_string(),
        (_, Some(Number::Real(v))) => v.to_string(),
        (DataType::VisibleString, None) => {
            let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
            format!("{:?}", String::from_utf8_lossy(bytes.get(..end).unwrap_or(bytes)))
        }
        _ if t.kind() != Kind::Bytes => format!("[{}] (not a {})", hex_bytes(bytes), t.name()),
        _ => format!("[{}]", hex_bytes(bytes)),
    }
}

/// A PDO the decoder knows the mapping of.
#[derive(Clone, Debug)]
struct PdoInfo {
    label: String,
    mapping: Vec<MappingEntry>,
}

/// The transfer a node's SDO server is in, as seen on the wire.
#[derive(Clone, Debug)]
struct SdoContext {
    index: u16,
    sub: u8,
    /// Segments seen so far (and their bytes), for the value at the end.
    segments: u32,
    data: Vec<u8>,
}

/// Turns frames into text; see the [module docs](self).
#[derive(Clone, Debug, Default)]
pub struct Decoder {
    names: Option<ObjectNames>,
    pdos: BTreeMap<u16, PdoInfo>,
    sdo: BTreeMap<u8, SdoContext>,
    unitek: Option<unitek::Ids>,
}

impl Decoder {
    /// A decoder that names objects from `names`, if given.
    pub fn new(names: Option<ObjectNames>) -> Self {
        Decoder { names, pdos: BTreeMap::new(), sdo: BTreeMap::new(), unitek: None }
    }

    /// Decodes frames on `rx` and `tx` as the UNITEK DS register protocol
    /// (requests to the drive, its replies), registers named from the
    /// dictionary's objects 0x2000 + REGID.
    pub fn add_unitek(&mut self, rx: u16, tx: u16) {
        self.unitek = Some(unitek::Ids { rx, tx });
    }

    /// Decodes frames on `cob_id` as a PDO called `label` (`TPDO1 node 127`)
    /// with this mapping.
    pub fn add_pdo(&mut self, cob_id: u16, label: &str, mapping: &[MappingEntry]) {
        self.pdos.insert(cob_id, PdoInfo { label: label.to_owned(), mapping: mapping.to_vec() });
    }

    /// `0x1018:01 Vendor-ID`, or just the multiplexer for an unknown object.
    pub fn object(&self, index: u16, sub: u8) -> String {
        match self.names.and_then(|n| n.name(index, sub)) {
            Some(name) => format!("0x{index:04X}:{sub:02X} {name}"),
            None => format!("0x{index:04X}:{sub:02X}"),
        }
    }

    fn value(&self, index: u16, sub: u8, bytes: &[u8]) -> String {
        format_value(self.names.and_then(|n| n.data_type(index, sub)), bytes)
    }

    /// The meaning of one frame; empty when the COB-ID has none this
    /// decoder knows. Call it for every frame, in bus order.
    pub fn decode(&mut self, frame: &CanFrame) -> String {
        if frame.is_extended_id() {
            return match (frame.raw_id(), frame.data()) {
                (EXIT_ID, [b'E', b'X', b'I', b'T']) => "QEMU exit request (status 0)".to_owned(),
                (EXIT_ID, [b'E', b'X', b'I', b'T', status]) => format!("QEMU exit request (status {status})"),
                _ => String::new(),
            };
        }
        let Some(cob_id) = frame.cob_id() else { return String::new() };
        let data = frame.data();
        if frame.is_remote_frame() {
            return match cob_id {
                0x701..=0x77F => format!("Node guarding request node {}", cob_id - 0x700),
                _ => format!("Remote request 0x{cob_id:03X}"),
            };
        }
        if let Some(p) = self.pdos.get(&cob_id) {
            return self.pdo(p, data);
        }
        if let Some(text) = self.unitek.and_then(|ids| unitek::decode(self.names, ids, cob_id, data)) {
            return text;
        }
        let node = (cob_id & 0x7F) as u8;
        match cob_id {
            0x000 => match NmtRequest::parse(data) {
                Ok(NmtRequest { command, node_id: 0 }) => format!("NMT {} (all nodes)", nmt_command_text(command)),
                Ok(NmtRequest { command, node_id }) => {
                    let text = nmt_command_text(command);
                    // "Start remote node 5", "Reset node 5", "Reset communication, node 5".
                    if text.ends_with("node") { format!("NMT {text} {node_id}") } else { format!("NMT {text}, node {node_id}") }
                }
                Err(_) => format!("NMT malformed ({} bytes)", data.len()),
            },
            0x080 => match data {
                [] => "SYNC".to_owned(),
                [counter] => format!("SYNC counter {counter}"),
                _ => format!("SYNC malformed ({} bytes)", data.len()),
            },
            0x081..=0x0FF => match Emcy::parse(data) {
                Some(Emcy { code: EmcyCode::NO_ERROR, register, .. }) => {
                    format!("EMCY node {node}: error reset, register 0x{register:02X}")
                }
                Some(e) => format!(
                    "EMCY node {node}: 0x{:04X} {}, register 0x{:02X}, info [{}]",
                    e.code.value(),
                    emcy_text(e.code.value()),
                    e.register,
                    hex_bytes(&e.info)
                ),
                None => format!("EMCY node {node}: malformed ({} bytes)", data.len()),
            },
            0x100 => "TIME stamp".to_owned(),
            0x181..=0x57F if node != 0 => {
                // Table 72: TPDOn at 0x080 + n × 0x100, RPDOn at 0x100 + n × 0x100.
                let (kind, n) = if cob_id & 0x80 != 0 { ("TPDO", cob_id >> 8) } else { ("RPDO", (cob_id >> 8) - 1) };
                format!("{kind}{n} node {node}: [{}] (mapping unknown)", hex_bytes(data))
            }
            0x581..=0x5FF => self.sdo_response(node, data),
            0x601..=0x67F => self.sdo_request(node, data),
            0x701..=0x77F => match data {
                [0x00] => format!("Boot-up node {node}"),
                [code] => match NmtStateCode::from_code(*code) {
                    Some(state) => format!("Heartbeat node {node}: {}", nmt_state_text(state)),
                    None => format!("Heartbeat node {node}: unknown state 0x{code:02X}"),
                },
                _ => format!("Heartbeat node {node}: malformed ({} bytes)", data.len()),
            },
            0x7E4 => "LSS response".to_owned(),
            0x7E5 => "LSS request".to_owned(),
            _ => String::new(),
        }
    }

    fn pdo(&self, p: &PdoInfo, data: &[u8]) -> String {
        match pdo::decode(&p.mapping, data) {
            Ok(values) => {
                let fields: Vec<String> = values
                    .iter()
                    .filter(|v| !v.entry.is_dummy())
                    .map(|v| {
                        let (index, sub) = (v.entry.index, v.entry.sub);
                        let name =
                            self.names.and_then(|n| n.name(index, sub)).map_or_else(|| format!("0x{index:04X}:{sub:02X}"), str::to_owned);
                        format!("{name}={}", self.value(index, sub, &v.to_le_bytes()))
                    })
                    .collect();
                format!("{}: {}", p.label, fields.join(", "))
            }
            Err(e) => format!("{}: {e}", p.label),
        }
    }

    fn abort(&self, who: &str, index: u16, sub: u8, code: u32) -> String {
        let text = AbortCode::from_code(code).map_or("not a CiA 301 abort code", abort_text);
        format!("SDO abort {who}{}: 0x{code:08X} {text}", self.object(index, sub))
    }

    fn sdo_request(&mut self, node: u8, data: &[u8]) -> String {
        let request = match SdoRequest::parse(data) {
            Ok(r) => r,
            Err(_) => return format!("SDO request to node {node}: [{}]", hex_bytes(data)),
        };
        match request {
            SdoRequest::InitiateUpload { index, sub } => {
                self.sdo.insert(node, SdoContext { index, sub, segments: 0, data: Vec::new() });
                format!("SDO upload request {}", self.object(index, sub))
            }
            SdoRequest::UploadSegment { toggle } => format!("SDO upload segment request (toggle {})", u8::from(toggle)),
            SdoRequest::InitiateDownload { index, sub, data: InitiateData::Expedited { data, size } } => {
                self.sdo.remove(&node);
                let bytes = data.get(..usize::from(size.unwrap_or(4))).unwrap_or(&data);
                format!("SDO download {} = {}", self.object(index, sub), self.value(index, sub, bytes))
            }
            SdoRequest::InitiateDownload { index, sub, data: InitiateData::Segmented { size } } => {
                self.sdo.insert(node, SdoContext { index, sub, segments: 0, data: Vec::new() });
                let size = size.map_or_else(|| "size not indicated".to_owned(), |s| format!("{s} bytes"));
                format!("SDO download {}: segmented, {size}", self.object(index, sub))
            }
            SdoRequest::DownloadSegment { data, len, last, .. } => {
                let bytes = data.get(..usize::from(len)).unwrap_or(&data);
                self.segment(node, bytes, last, "download")
            }
            SdoRequest::Abort { index, sub, code } => {
                self.sdo.remove(&node);
                self.abort("by the master ", index, sub, code)
            }
            SdoRequest::BlockDownload(_) | SdoRequest::BlockUpload(_) => format!("SDO block transfer request to node {node}"),
        }
    }

    fn sdo_response(&mut self, node: u8, data: &[u8]) -> String {
        let response = match SdoResponse::parse(data) {
            Ok(r) => r,
            Err(_) => return format!("SDO response from node {node}: [{}]", hex_bytes(data)),
        };
        match response {
            SdoResponse::InitiateUpload { index, sub, data: InitiateData::Expedited { data, size } } => {
                self.sdo.remove(&node);
                let bytes = data.get(..usize::from(size.unwrap_or(4))).unwrap_or(&data);
                format!("SDO upload {} = {}", self.object(index, sub), self.value(index, sub, bytes))
            }
            SdoResponse::InitiateUpload { index, sub, data: InitiateData::Segmented { size } } => {
                let size = size.map_or_else(|| "size not indicated".to_owned(), |s| format!("{s} bytes"));
                format!("SDO upload {}: segmented, {size}", self.object(index, sub))
            }
            SdoResponse::UploadSegment { data, len, last, .. } => {
                let bytes = data.get(..usize::from(len)).unwrap_or(&data);
                self.segment(node, bytes, last, "upload")
            }
            SdoResponse::InitiateDownload { index, sub } => format!("SDO download {} done", self.object(index, sub)),
            SdoResponse::DownloadSegment { toggle } => format!("SDO download segment confirmed (toggle {})", u8::from(toggle)),
            SdoResponse::Abort { index, sub, code } => {
                self.sdo.remove(&node);
                self.abort("", index, sub, code)
            }
            SdoResponse::BlockDownload(_) | SdoResponse::BlockUpload(_) => format!("SDO block transfer response from node {node}"),
        }
    }

    /// One segment of a segmented transfer; the last one shows the whole value.
    fn segment(&mut self, node: u8, bytes: &[u8], last: bool, what: &str) -> String {
        let Some(ctx) = self.sdo.get_mut(&node) else {
            return format!("SDO {what} segment ({} bytes{})", bytes.len(), if last { ", last" } else { "" });
        };
        ctx.segments += 1;
        ctx.data.extend_from_slice(bytes);
        let n = ctx.segments;
        if !last {
            return format!("SDO {what} segment {n} ({} bytes)", bytes.len());
        }
        let (index, sub, value) = (ctx.index, ctx.sub, std::mem::take(&mut ctx.data));
        self.sdo.remove(&node);
        let mut s = format!("SDO {what} segment {n} ({} bytes, last): {}", bytes.len(), self.object(index, sub));
        let _ = write!(s, " = {}", self.value(index, sub, &value));
        s
    }
}
