//! Writes with the services' rules ([`Ctx::write_object`]) and the node's
//! [`ObjectAccess`] for SDO: every access goes through here, so each
//! communication object is validated by, and reconfigures, the service that
//! owns it (CiA 301 §7.5.2), and every object reaches the device hooks.

use crate::abort::AbortCode;
use crate::od::access::{copy_from, small_value, upload_value};
use crate::od::index;
use crate::od::{Dictionary, Entry, ObjectAccess, ObjectDictionary, checked_entry, precheck, store_checked, u32_exact};
use crate::services::store::{Job, LOAD, SAVE, Scope, StoreError};
use core::cell::Cell;
use core::marker::PhantomData;

use super::app::{Application, Ctx, HookSide, ServiceOptions, Source};
use super::comm::Services;
use crate::services::nmt::NmtState;
use crate::storage::Storage;
use crate::time::At;

/// One SDO access (or application request) in flight: the device's hooks
/// around the context's writes.
pub(crate) struct Router<'c, 'a, A: Application, O: ObjectDictionary> {
    pub ctx: &'c mut Ctx<'a>,
    pub app: &'c mut A,
    pub by: Source,
    /// The node's dictionary type: whether it links storage (`Services::storage`).
    pub od: PhantomData<O>,
    /// For an SDO request: a 0x1010/0x1011 command starts the node's store
    /// in stages and notes its (index, sub) here, and the SDO answer waits
    /// for the store's end. Elsewhere (`None`) the store runs in the call.
    pub staged: Option<&'c Cell<Option<(u16, u8)>>>,
}

/// What accesses changed beyond the objects themselves, for the node to
/// follow up once the [`Ctx`] is gone.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SdoEffects {
    /// The image bytes (offset, length) the one plain write of an object
    /// changed (length 0: none): only the TPDOs mapping them look for
    /// changed data.
    pub wrote: (u16, u16),
    /// What else the node follows up after the access.
    pub follow: Follow,
    /// A device error of this 0x1029 sub-index (0: none) occurred: the node
    /// applies the error behaviour.
    pub error_class: u8,
    /// The device asked for a reset node ([`super::Ctx::reset_node`]).
    pub reset_node: bool,
}

/// The part of [`SdoEffects`] the node follows up after every access
/// besides `wrote`: four bytes, like `wrote`, so that both are passed in
/// registers (an [`SdoEffects`] is copied to the stack for each call).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Follow {
    /// An SDO server parameter (0x1200–0x127F) was written: the node reads them again.
    pub sdo_changed: bool,
    /// An object that decides which COB-IDs the node consumes was written:
    /// the node rebuilds its acceptance list (not after every SDO request,
    /// which would cost more than the request itself).
    pub consumed_changed: bool,
    /// A write was attempted that may have changed any part of the image
    /// (even if it failed): every TPDO looks for changed data at the next
    /// process, which an upload alone does not need.
    pub written: bool,
    /// A hook or a write changed a service beyond the dictionary (an error
    /// raised or cleared, a communication object written): the next
    /// process runs every service.
    pub services: bool,
}

/// The abort code of a failed store or restore.
pub(super) fn store_abort(e: StoreError) -> AbortCode {
    match e {
        StoreError::Storage(_) => AbortCode::Hardware,
        StoreError::TooLarge | StoreError::NotStored => AbortCode::CannotStore,
        StoreError::Busy => AbortCode::DeviceState,
    }
}

impl Ctx<'_> {
    /// 0x1010/0x1011 on a node whose dictionary links no storage
    /// (`Services::storage` off while the dictionary lists the objects, as
    /// the `ds301-lean` reference has it): nothing can be stored.
    pub(super) fn no_store(&mut self, index: u16, sub: u8) -> Result<(), AbortCode> {
        self.effects.follow.written = true;
        self.dict.find(index, sub)?;
        Err(AbortCode::CannotStore)
    }

    fn plain(&mut self) -> crate::od::DictionaryAccess<'_> {
        crate::od::DictionaryAccess { dictionary: self.dict, image: self.image }
    }

    /// 0x1010 "save" of `scope`, leaving the device's own objects as stored.
    pub(super) fn save_job(&self, scope: Scope) -> Job {
        Job::save(scope, self.options.not_saved_by_1010)
    }

    /// Runs a store in this call; refused (0x08000022) while the node's
    /// store in stages is in progress: both would write the same region
    /// ([`Ctx::storing`] tells a device's hook to wait for its end).
    pub(super) fn run_store(&mut self, job: Job) -> Result<(), AbortCode> {
        if self.hook.store.busy() {
            return Err(store_abort(StoreError::Busy));
        }
        job.finish(self.dict, self.image, self.hook.node_id, self.storage).map_err(store_abort)
    }

    /// 0x1010 / 0x1011: the signature triggers the command; the entry itself keeps
    /// its read-back value (the capability bits). With `staged`, the node
    /// runs the store a stage per `process` call (see [`Router::staged`]).
    /// `options`: the device's (the context's own), passed by a caller that
    /// knows them as a constant, so that a device without
    /// [`ServiceOptions::not_saved_by_1010`] links no search for their bytes.
    pub(super) fn store_command(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
        options: &'static ServiceOptions,
        staged: Option<&Cell<Option<(u16, u8)>>>,
    ) -> Result<(), AbortCode> {
        // A store command may change any value (a restore, at the next reset).
        self.effects.follow.written = true;
        self.dict.find(index, sub)?;
        let scope = Scope::from_sub(sub).ok_or(if sub == 0 { AbortCode::ReadOnly } else { AbortCode::CannotStore })?;
        let (signature, is_save) = if index == index::STORE_PARAMETERS { (SAVE, true) } else { (LOAD, false) };
        if u32_exact(data)? != signature {
            return Err(AbortCode::CannotStore);
        }
        let job = Job::command(scope, is_save, options.not_saved_by_1010);
        match staged {
            Some(answer) if !self.hook.store.busy() => {
                self.hook.store = job;
                answer.set(Some((index, sub)));
                Ok(())
            }
            // Or another store in stages is under way (begun on another SDO server).
            _ => self.run_store(job),
        }
    }

    /// [`precheck`]: the checks every download passes before the object's
    /// own rules, `LIMITS` as there; the entry, for [`Ctx::route_write`].
    pub(super) fn precheck<const LIMITS: bool>(&self, index: u16, sub: u8, data: &[u8]) -> Result<&'static Entry, AbortCode> {
        precheck::<LIMITS>(self.dict, index, sub, data)
    }
}

impl Ctx<'_> {
    /// A write no service owns (an application or profile object): the
    /// dictionary's own, remembering which bytes changed. The precheck
    /// looked the entry up and checked the value: no second look-up.
    pub(super) fn write_plain(&mut self, entry: &'static Entry, data: &[u8]) -> Result<(), AbortCode> {
        write_plain(self.image, &mut self.effects, entry, data)
    }
}

/// [`Ctx::write_plain`] on the image and the effects alone.
#[inline(always)]
fn write_plain(image: &mut [u8], effects: &mut SdoEffects, entry: &'static Entry, data: &[u8]) -> Result<(), AbortCode> {
    let changed = store_checked(image, entry, data)?;
    if !changed {
        // The same value again: no TPDO has new data.
    } else if effects.wrote.1 == 0 {
        effects.wrote = (entry.offset, entry.len.into());
    } else {
        // A second write in one access: any TPDO may look.
        effects.follow.written = true;
    }
    Ok(())
}

impl SdoEffects {
    /// `len` image bytes at `offset` changed: the TPDOs mapping them look
    /// for a change; after a second write in one access, every TPDO (as
    /// `write_plain` does).
    // Out of line: every value the device sets comes here.
    #[inline(never)]
    pub(super) fn wrote_bytes(&mut self, offset: u16, len: u16) {
        if self.wrote.1 == 0 {
            self.wrote = (offset, len);
        } else {
            self.follow.written = true;
        }
    }
}

impl<A: Application, O: ObjectDictionary> Router<'_, '_, A, O> {
    /// [`ObjectAccess::read`], from `entry` when the caller already looked
    /// it up and checked it for an upload.
    fn read_from(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8], entry: Option<&'static Entry>) -> Result<usize, AbortCode> {
        if let Some(r) = self.app.read(self.ctx, index, sub, offset, buf) {
            return r;
        }
        let value = match entry {
            // `upload_small` checked it with `upload_value` and took its
            // size from there: no second check, and its first `buf.len()`
            // bytes end before a string's NUL.
            Some(entry) => self.ctx.dict.value(self.ctx.image, entry),
            None => upload_value(self.ctx.dict, self.ctx.image, self.ctx.dict.find(index, sub)?)?,
        };
        Ok(copy_from(buf, value.get(offset..).unwrap_or(&[])))
    }

    /// A complete write with the hooks: serve, the dictionary's checks,
    /// validate, the owner's rules, then react.
    pub(super) fn write_with_hooks(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        if let Some(r) = self.app.write(self.ctx, index, sub, data) {
            self.ctx.effects.follow.written = true;
            return r;
        }
        // 0x1010/0x1011 take a 4-byte signature whatever their entries say.
        let store = index == index::STORE_PARAMETERS || index == index::RESTORE_DEFAULT_PARAMETERS;
        // `HAS_LIMITS` is a constant: one of the two is linked.
        let entry = match (store, O::HAS_LIMITS) {
            (true, _) => None,
            (false, true) => Some(self.ctx.precheck::<true>(index, sub, data)?),
            (false, false) => Some(self.ctx.precheck::<false>(index, sub, data)?),
        };
        self.app.check_write(self.ctx, index, sub, data)?;
        match entry {
            Some(entry) => self.ctx.route_write(index, sub, data, entry, A::OPTIONS.pdo_rewrite_while_valid)?,
            None => {
                if O::SERVICES.storage {
                    self.ctx.store_command(index, sub, data, &A::OPTIONS, self.staged)
                } else {
                    self.ctx.no_store(index, sub)
                }?;
            }
        }
        self.app.written(self.ctx, index, sub, self.by);
        Ok(())
    }
}

impl<A: Application, O: ObjectDictionary> ObjectAccess for Router<'_, '_, A, O> {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        if let Some(r) = self.app.upload_size(self.ctx, index, sub) {
            return r;
        }
        self.ctx.plain().upload_size(index, sub)
    }

    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        self.read_from(index, sub, offset, buf, None)
    }

    fn upload_small(&mut self, index: u16, sub: u8, buf: &mut [u8; 4]) -> Result<usize, AbortCode> {
        // The hooks in the order upload_size, read would call them; the
        // plain tables looked up once for both.
        let (size, entry) = match self.app.upload_size(self.ctx, index, sub) {
            Some(r) => (r?, None),
            None => {
                let entry = self.ctx.dict.find(index, sub)?;
                (upload_value(self.ctx.dict, self.ctx.image, entry)?.len(), Some(entry))
            }
        };
        let Some(dst) = buf.get_mut(..size).filter(|_| size != 0) else { return Ok(size) };
        self.read_from(index, sub, 0, dst, entry)?;
        Ok(size)
    }

    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
        if let Some(r) = self.app.download_check(self.ctx, index, sub, size) {
            return r;
        }
        // The router serves a node with SDO hooks only (a node without
        // them serves through `SdoParts`).
        download_check_plain(self.ctx.dict, index, sub, size)
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.write_with_hooks(index, sub, data)
    }
}

/// The SDO servers' way into the node for one request (or one poll of
/// the servers) of a device without SDO hooks ([`Application::SDO_HOOKS`]):
/// the parts the hooks' [`Ctx`] is made of, that context built only for a
/// write to a communication object ([`SdoParts::write`]). Uploads, a
/// download's checks and the writes of the other objects reach the
/// dictionary alone, as the router does without a hook to answer. Built
/// for every request, the context kept the general expedited upload at
/// 626 thumbv7m instructions, over the 600 aim (589 without it).
pub(super) struct SdoParts<'c, A, O, C, S> {
    pub od: &'c mut O,
    pub app: &'c mut A,
    pub services: &'c mut C,
    pub storage: &'c mut S,
    pub hook: &'c mut HookSide,
    pub state: NmtState,
    pub now: At,
    /// As [`Router::staged`].
    pub staged: Option<&'c Cell<Option<(u16, u8)>>>,
    /// What the write changed beyond its object.
    pub effects: SdoEffects,
}

impl<A: Application, O: ObjectDictionary, C: Services, S: Storage> SdoParts<'_, A, O, C, S> {
    fn plain(&mut self) -> crate::od::DictionaryAccess<'_> {
        crate::od::DictionaryAccess { dictionary: self.od.dictionary(), image: self.od.image_mut() }
    }
}

impl<A: Application, O: ObjectDictionary, C: Services, S: Storage> ObjectAccess for SdoParts<'_, A, O, C, S> {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        self.plain().upload_size(index, sub)
    }

    // Not `self.plain().read(..)`, the same reading: that links
    // `DictionaryAccess`'s own copy of it (ds301 134 bytes more).
    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let dict = self.od.dictionary();
        let value = upload_value(dict, self.od.image(), dict.find(index, sub)?)?;
        Ok(copy_from(buf, value.get(offset..).unwrap_or(&[])))
    }

    fn upload_small(&mut self, index: u16, sub: u8, buf: &mut [u8; 4]) -> Result<usize, AbortCode> {
        let (head, size) = small_value(self.od.dictionary(), self.od.image(), index, sub)?;
        *buf = head;
        Ok(size)
    }

    fn download_check(&mut self, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
        if !O::SERVICES.block_sdo {
            return download_check_apart(self.od.dictionary(), index, sub, size);
        }
        download_check_plain(self.od.dictionary(), index, sub, size)
    }

    /// The write with the services' rules, in the context built here; an
    /// application or profile object (from 0x2000 on), which no service
    /// owns, without one: the dictionary's checks and the value stored, as
    /// `Router::write_with_hooks` and `Ctx::route_write` do when no hook
    /// answers.
    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let dict = self.od.dictionary();
        if index >= index::MANUFACTURER_SPECIFIC {
            // `HAS_LIMITS` is a constant: one of the two is linked.
            let entry = if O::HAS_LIMITS { precheck::<true>(dict, index, sub, data) } else { precheck::<false>(dict, index, sub, data) }?;
            return write_plain(self.od.image_mut(), &mut self.effects, entry, data);
        }
        let mut ctx = Ctx {
            dict,
            image: self.od.image_mut(),
            services: self.services,
            storage: self.storage,
            state: self.state,
            now: self.now,
            options: &A::OPTIONS,
            effects: SdoEffects::default(),
            hook: self.hook,
        };
        let result = Router { ctx: &mut ctx, app: self.app, by: Source::Sdo, od: PhantomData::<O>, staged: self.staged }
            .write_with_hooks(index, sub, data);
        self.effects = ctx.effects;
        result
    }
}

/// [`download_check_plain`] out of line, for [`SdoParts`] (a node without
/// SDO hooks, [`Application::SDO_HOOKS`]) without block SDO: one copy of
/// the check for the initiate and the segmented download's end, and no
/// [`Ctx`] built for it (with one escaping into an out-of-line check, the
/// services' vtable, that only a hook calls, stayed linked: ds301-lean
/// 60 bytes). With block SDO the plain check stays in line.
#[inline(never)]
fn download_check_apart(dict: &Dictionary, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
    download_check_plain(dict, index, sub, size)
}

/// [`ObjectAccess::download_check`] when no hook answered: on the dictionary alone.
#[inline(always)]
fn download_check_plain(dict: &Dictionary, index: u16, sub: u8, size: Option<usize>) -> Result<(), AbortCode> {
    if index != index::STORE_PARAMETERS && index != index::RESTORE_DEFAULT_PARAMETERS {
        // The checks of a write but the limits (`precheck`), one copy for both.
        return checked_entry(dict, index, sub, size, false).map(drop);
    }
    // 0x1010/0x1011 take a 4-byte signature whatever their entries say,
    // and refuse sub 0 only after its length.
    dict.find(index, sub)?;
    match size {
        Some(n) if n > 4 => Err(AbortCode::LengthTooHigh),
        Some(n) if n < 4 => Err(AbortCode::LengthTooLow),
        _ if sub == 0 => Err(AbortCode::ReadOnly),
        _ => Ok(()),
    }
}
