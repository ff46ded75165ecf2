//! The node's [`ObjectAccess`]: every SDO access goes through here, so each
//! communication object is validated by, and reconfigures, the service that
//! owns it (CiA 301 §7.5.2), and application objects reach the device hooks.

use crate::abort::AbortCode;
use crate::id::CobId;
use crate::od::{DataType, Dictionary, ObjectAccess};
use crate::services::store::{self, LOAD, SAVE, Scope, StoreError};
use crate::storage::Storage;
use crate::time::Instant;

use super::app::Application;
use super::comm::Comm;

/// One SDO access in flight: borrows what the owner of each object needs.
pub(crate) struct Router<'a, A: Application, const R: usize, const T: usize, const HB: usize> {
    pub dict: &'static Dictionary,
    pub image: &'a mut [u8],
    pub app: &'a mut A,
    pub comm: &'a mut Comm<R, T, HB>,
    pub storage: &'a mut dyn Storage,
    pub node_id: u8,
    pub now: Instant,
    /// What the accesses so far mean for the rest of the node.
    pub effects: SdoEffects,
}

/// What SDO accesses changed beyond the objects themselves, for the node to
/// follow up once the [`Router`] is gone.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SdoEffects {
    /// An SDO server parameter (0x1200–0x127F) was written: the node reads them again.
    pub sdo_changed: bool,
    /// An object that decides which COB-IDs the node consumes was written:
    /// the node rebuilds its acceptance list (not after every SDO request,
    /// which would cost more than the request itself).
    pub consumed_changed: bool,
    /// A write was attempted (it may have changed the image even if it
    /// failed): the TPDOs look for changed data at the next process, which
    /// an upload alone does not need.
    pub written: bool,
}

fn u32_of(data: &[u8]) -> Result<u32, AbortCode> {
    match *data {
        [a, b, c, d] => Ok(u32::from_le_bytes([a, b, c, d])),
        [_, _, _, _, _, ..] => Err(AbortCode::LengthTooHigh),
        _ => Err(AbortCode::LengthTooLow),
    }
}

impl<A: Application, const R: usize, const T: usize, const HB: usize> Router<'_, A, R, T, HB> {
    fn plain(&mut self) -> crate::od::DictionaryAccess<'_> {
        crate::od::DictionaryAccess { dictionary: self.dict, image: self.image }
    }

    /// 0x1010 / 0x1011: the signature triggers the command; the entry itself keeps
    /// its read-back value (the capability bits).
    fn store_command(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.dict.find(index, sub)?;
        let scope = Scope::from_sub(sub).ok_or(if sub == 0 { AbortCode::ReadOnly } else { AbortCode::CannotStore })?;
        let (signature, is_save) = if index == 0x1010 { (SAVE, true) } else { (LOAD, false) };
        if u32_of(data)? != signature {
            return Err(AbortCode::CannotStore);
        }
        let result = if is_save {
            store::save(self.dict, self.image, self.node_id, self.storage, scope)
        } else {
            store::restore_defaults(self.dict, self.image, self.node_id, self.storage, scope)
        };
        result.map_err(|e| match e {
            StoreError::Storage(_) => AbortCode::Hardware,
            StoreError::TooLarge => AbortCode::CannotStore,
        })
    }

    fn current_u32(&self, index: u16, sub: u8) -> Option<u32> {
        self.dict.read_u32(self.image, index, sub)
    }

    /// The checks every download of a communication object passes before
    /// the object's own rules: the entry exists and is writable, the length
    /// fits, and the value is within the EDS limits. So an access or range
    /// error gets its own abort code (0x06010002, 0x0607001x, 0x06090031/32)
    /// whatever the object's owner would say about the value.
    fn precheck(&self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let entry = self.dict.find(index, sub)?;
        // A writable DOMAIN has no length or limits to check here.
        if entry.data_type == DataType::Domain && entry.writable() {
            return Ok(());
        }
        Ok(self.dict.check_write(entry, data)?)
    }

    /// 0x1014 COB-ID EMCY (CiA 301 §7.5.2.15): bit 31 set = EMCY off. No
    /// 29-bit CAN-ID (bits 11..30 are 0), no CAN-ID 0, no restricted CAN-ID
    /// while valid; the CAN-ID changes only while EMCY is or becomes off.
    fn write_emcy_cob_id(&mut self, data: &[u8]) -> Result<(), AbortCode> {
        let new = CobId(u32_of(data)?);
        let moves =
            self.current_u32(0x1014, 0).map(CobId).is_some_and(|old| old.is_valid() && new.is_valid() && old.can_id() != new.can_id());
        if new.0 & !(CobId::BIT31 | 0x7FF) != 0 || new.can_id() == 0 || (new.is_valid() && new.is_restricted()) || moves {
            return Err(AbortCode::InvalidValue);
        }
        self.plain().write(0x1014, 0, data)?;
        self.comm.configure_emcy(self.dict, self.image);
        Ok(())
    }

    /// 0x1012 COB-ID TIME (CiA 301 §7.5.2.13): bit 31 consume, bit 30
    /// produce. No 29-bit CAN-ID, no restricted CAN-ID while consumed or produced.
    fn write_time_cob_id(&mut self, data: &[u8]) -> Result<(), AbortCode> {
        let new = CobId(u32_of(data)?);
        let used = new.0 & (CobId::BIT31 | CobId::BIT30) != 0;
        if new.is_extended() || (used && new.is_restricted()) {
            return Err(AbortCode::InvalidValue);
        }
        self.plain().write(0x1012, 0, data)?;
        self.comm.reconfigure(0x1012, self.dict, self.image, self.node_id, self.now);
        Ok(())
    }

    /// An SDO server parameter 0x1200 + i (CiA 301 §7.5.2.33). Sub 1 and 2,
    /// the COB-IDs: bit 31 set = not valid, bit 30 (dynamic) is kept, no
    /// 29-bit CAN-ID; a valid COB-ID may not use a restricted CAN-ID (the
    /// default server keeps its own pre-defined ones), and its CAN-ID
    /// changes only while it is or becomes not valid. Sub 3, the client's
    /// node-ID: 0 (none assigned) or 1..=127.
    fn write_sdo_server(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        match sub {
            1 | 2 => {
                let new = CobId(u32_of(data)?);
                let own = if sub == 1 { 0x600 } else { 0x580 } + u16::from(self.node_id);
                let restricted = new.is_restricted() && !(index == 0x1200 && new.can_id() == own);
                let old = self.current_u32(index, sub).map(CobId);
                let moves = old.is_some_and(|old| old.is_valid() && new.is_valid() && old.can_id() != new.can_id());
                if new.is_extended() || (new.is_valid() && restricted) || moves {
                    return Err(AbortCode::InvalidValue);
                }
            }
            3 if matches!(data, [id] if *id > 127) => return Err(AbortCode::InvalidValue),
            _ => {}
        }
        self.plain().write(index, sub, data)?;
        self.effects.sdo_changed = true;
        Ok(())
    }
}

impl<A: Application, const R: usize, const T: usize, const HB: usize> ObjectAccess for Router<'_, A, R, T, HB> {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        if index >= 0x2000
            && let Some(r) = self.app.upload_size(index, sub)
        {
            return r;
        }
        self.plain().upload_size(index, sub)
    }

    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        if index >= 0x2000
            && let Some(r) = self.app.read(index, sub, offset, buf)
        {
            return r;
        }
        self.plain().read(index, sub, offset, buf)
    }

    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
        if index >= 0x2000
            && let Some(r) = self.app.download_check(index, sub, size)
        {
            return r;
        }
        if index == 0x1010 || index == 0x1011 {
            // The signature is 4 bytes, whatever the entry's own size.
            self.dict.find(index, sub)?;
            return match size {
                Some(n) if n > 4 => Err(AbortCode::LengthTooHigh),
                Some(n) if n < 4 => Err(AbortCode::LengthTooLow),
                _ if sub == 0 => Err(AbortCode::ReadOnly),
                _ => Ok(()),
            };
        }
        self.plain().download_check(index, sub, size)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.effects.written = true;
        let result = self.route_write(index, sub, data);
        // SYNC, TIME, heartbeat consumers, SDO servers, RPDOs and TPDOs (RTR).
        if result.is_ok() && matches!(index, 0x1005 | 0x1012 | 0x1016 | 0x1200..=0x127F | 0x1400..=0x15FF | 0x1800..=0x19FF) {
            self.effects.consumed_changed = true;
        }
        result
    }
}

impl<A: Application, const R: usize, const T: usize, const HB: usize> Router<'_, A, R, T, HB> {
    fn route_write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        // 0x1010/0x1011 take a 4-byte signature whatever their entries say.
        if index < 0x2000 && index != 0x1010 && index != 0x1011 {
            self.precheck(index, sub, data)?;
        }
        match index {
            0x1003 => {
                // The precheck found the entry writable.
                if sub != 0 {
                    return Err(AbortCode::ReadOnly);
                }
                // CiA 301 §7.5.2.4: only 0 may be written, and it clears the history.
                match data {
                    [0] => {
                        self.comm.clear_history(self.dict, self.image);
                        Ok(())
                    }
                    [_] => Err(AbortCode::InvalidValue),
                    [] => Err(AbortCode::LengthTooLow),
                    _ => Err(AbortCode::LengthTooHigh),
                }
            }
            0x1010 | 0x1011 => self.store_command(index, sub, data),
            0x1012 if sub == 0 => self.write_time_cob_id(data),
            0x1014 if sub == 0 => self.write_emcy_cob_id(data),
            0x1016 if sub > 0 => {
                let value = u32_of(data)?;
                if self.comm.consumers.conflicts(usize::from(sub) - 1, value) {
                    return Err(AbortCode::ParameterIncompatible);
                }
                self.plain().write(index, sub, data)?;
                self.comm.consumers.configure(usize::from(sub) - 1, value);
                Ok(())
            }
            0x1029 if sub > 0 => {
                if matches!(data, [v] if *v > 2) {
                    return Err(AbortCode::InvalidValue);
                }
                self.plain().write(index, sub, data)
            }
            0x1005..=0x1007 | 0x1019 => self.comm.write_sync(index, sub, data, self.dict, self.image),
            0x1200..=0x127F => self.write_sdo_server(index, sub, data),
            0x100C | 0x100D | 0x1015 | 0x1017 => {
                self.plain().write(index, sub, data)?;
                self.comm.reconfigure(index, self.dict, self.image, self.node_id, self.now);
                Ok(())
            }
            0x1400..=0x1BFF => self.comm.write_pdo(index, sub, data, self.dict, self.image),
            _ => {
                if index >= 0x2000
                    && let Some(r) = self.app.write(index, sub, data)
                {
                    return r;
                }
                self.plain().write(index, sub, data)
            }
        }
    }
}
