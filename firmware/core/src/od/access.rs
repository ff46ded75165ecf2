//! What services see of the dictionary: [`ObjectAccess`].
//!
//! The SDO server and the PDOs never touch the RAM image directly. They go
//! through this trait, which the node implements by routing each object to
//! its owner: communication objects to the service that validates them (a
//! PDO COB-ID may not change while the PDO is valid, CiA 301 §7.5.2.35),
//! application objects to the device's hooks, everything else to the
//! generated tables.

use crate::abort::AbortCode;

/// Access to object values, by (index, sub-index), as an SDO server needs it.
pub trait ObjectAccess {
    /// Size in bytes of the value an upload of (index, sub) would send;
    /// checks that the entry exists and is readable.
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode>;

    /// Copies bytes `offset..offset + buf.len()` of the value into `buf`;
    /// returns how many were copied (fewer at the end of the value).
    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode>;

    /// The size of (index, sub), and its value in `buf` when it has 1 to
    /// 4 bytes (an expedited upload): what [`ObjectAccess::upload_size`]
    /// and [`ObjectAccess::read`] say, with one dictionary look-up where
    /// an implementation can. Called on a type, never through `dyn` (the
    /// SDO server's expedited upload takes the node's router or its
    /// `SdoParts` by type), so
    /// that it takes no place in the vtables.
    fn upload_small(&mut self, index: u16, sub: u8, buf: &mut [u8; 4]) -> Result<usize, AbortCode>
    where
        Self: Sized,
    {
        let size = self.upload_size(index, sub)?;
        if let Some(dst) = buf.get_mut(..size).filter(|_| size != 0) {
            self.read(index, sub, 0, dst)?;
        }
        Ok(size)
    }

    /// Checks before a download starts that (index, sub) exists, is writable,
    /// and, when the client announced it, that `size` fits the entry.
    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode>;

    /// Writes a complete value, with every check and side effect of the object.
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;
}

/// A borrowed access, so that a `&mut dyn ObjectAccess` serves where an
/// `ObjectAccess` type is asked for (the SDO server's expedited transfers
/// take the node's router by type, other callers pass a `dyn`).
impl<T: ObjectAccess + ?Sized> ObjectAccess for &mut T {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        (**self).upload_size(index, sub)
    }

    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        (**self).read(index, sub, offset, buf)
    }

    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
        (**self).download_check(index, sub, size)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        (**self).write(index, sub, data)
    }
}

use super::{DataType, Dictionary, Entry};

/// [`ObjectAccess`] straight onto a generated dictionary and its RAM image,
/// with the checks CiA 301 asks of every entry and no side effects.
#[derive(Debug)]
pub struct DictionaryAccess<'a> {
    /// The flash tables.
    pub dictionary: &'static Dictionary,
    /// The RAM image.
    pub image: &'a mut [u8],
}

impl DictionaryAccess<'_> {
    fn value(&self, index: u16, sub: u8) -> Result<&[u8], AbortCode> {
        let entry = self.dictionary.find(index, sub)?;
        upload_value(self.dictionary, self.image, entry)
    }
}

/// Copies what fits of `src` into `buf`; returns the bytes copied. A byte
/// loop: an SDO read moves at most 7 bytes, less than a `memcpy` call costs.
pub(crate) fn copy_from(buf: &mut [u8], src: &[u8]) -> usize {
    let mut n = 0;
    for (d, s) in buf.iter_mut().zip(src) {
        *d = *s;
        // At most `buf.len()` steps.
        #[allow(clippy::arithmetic_side_effects)]
        {
            n += 1;
        }
    }
    n
}

/// What an SDO upload of `entry` reads from the plain tables.
pub(crate) fn upload_value<'a>(dictionary: &Dictionary, image: &'a [u8], entry: &Entry) -> Result<&'a [u8], AbortCode> {
    if !entry.readable() {
        return Err(AbortCode::WriteOnly);
    }
    if entry.data_type == DataType::Domain {
        // A DOMAIN's bytes belong to the application; the plain tables have none.
        return Err(AbortCode::NoData);
    }
    let value = dictionary.value(image, entry);
    // 0x1003 sub 1.. above sub 0's count hold no error (CiA 301 §7.5.2.4):
    // "no data available", as CANopenNode answers. A recorded entry is
    // never 0 (error code 0000 is not recorded) and clearing zeroes every
    // entry, so a zero entry is exactly one above the count, and no lookup
    // of sub 0 is needed.
    if entry.index == super::index::PRE_DEFINED_ERROR_FIELD && entry.sub != 0 && value.iter().all(|&b| b == 0) {
        return Err(AbortCode::NoData);
    }
    Ok(if entry.data_type == DataType::VisibleString { super::until_nul(value) } else { value })
}

/// What an SDO upload of (index, sub) reads from the plain tables, for an
/// expedited answer: the value's size, and its first bytes (up to 4, the
/// rest 0) as [`super::le_u32`] reads them: one call where gathering them
/// one checked byte at a time took 40 bytes in line (ds301-lean).
/// The expedited upload of a node without SDO hooks reads through it.
// Left to the inliner since its second caller (the in-place upload) went:
// ds301 134 bytes less, ds301-lean 54 (out of line or forced in line, more).
pub(crate) fn small_value(dictionary: &Dictionary, image: &[u8], index: u16, sub: u8) -> Result<([u8; 4], usize), AbortCode> {
    let value = upload_value(dictionary, image, dictionary.find(index, sub)?)?;
    Ok((super::le_u32(value).to_le_bytes(), value.len()))
}

impl ObjectAccess for DictionaryAccess<'_> {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        self.value(index, sub).map(<[u8]>::len)
    }

    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let value = self.value(index, sub)?;
        Ok(copy_from(buf, value.get(offset..).unwrap_or(&[])))
    }

    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
        self.dictionary.check_size(self.dictionary.find(index, sub)?, size)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.dictionary.write(self.image, index, sub, data)
    }
}
