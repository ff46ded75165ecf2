//! The node's [`ObjectAccess`]: every SDO access goes through here, so each
//! communication object is validated by, and reconfigures, the service that
//! owns it (CiA 301 §7.5.2), and application objects reach the device hooks.

use crate::abort::AbortCode;
use crate::od::{Dictionary, ObjectAccess};
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
        let v = self.dict.read(self.image, index, sub).ok()?;
        u32_of(v).ok()
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
        match index {
            0x1003 => {
                let entry = self.dict.find(index, sub)?;
                if sub != 0 || !entry.writable() {
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
            0x1014 => {
                let new = u32_of(data)?;
                // The COB-ID may change only while EMCY is off (bit 31), as for PDOs.
                if let Some(old) = self.current_u32(0x1014, 0)
                    && old & 0x8000_0000 == 0
                    && new & 0x8000_0000 == 0
                    && old & 0x7FF != new & 0x7FF
                {
                    return Err(AbortCode::InvalidValue);
                }
                if new & 0x2000_0000 != 0 || new & 0x7FF == 0 {
                    return Err(AbortCode::InvalidValue);
                }
                self.plain().write(index, sub, data)?;
                self.comm.configure_emcy(self.dict, self.image);
                Ok(())
            }
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
            0x100C | 0x100D | 0x1012 | 0x1015 | 0x1017 | 0x1200..=0x12FF => {
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
