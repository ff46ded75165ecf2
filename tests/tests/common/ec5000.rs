//! The EC5000 roller on the bench: node 5 with the axis model, driven by
//! its fixed PDOs in virtual time.

use super::{Bench, F, ms};
use firmware::devices::ec5000::{self, Roller};
use hal_host::storage::MemStorage;

/// The EC5000 on a host storage.
pub type Ec5000 = Bench<ec5000::od::Ram, ec5000::App, MemStorage, 4, 4, 1>;

/// The node-ID on the bench.
pub const ID: u8 = 5;
/// RPDO1 (0x6040, 0x6060, 0x6081), RPDO2 (0x6040, 0x607A), RPDO3 (0x6040, 0x60FF).
pub const RPDO1: u16 = 0x205;
pub const RPDO2: u16 = 0x305;
pub const RPDO3: u16 = 0x405;
/// EMCY, and TPDO1 (0x6041, 0x6061, 0x1001, 0x2200 sub 6, 0x6077), TPDO2
/// (0x6041, 0x6064), TPDO3 (0x6041, 0x606C; on SYNC).
pub const EMCY: u16 = 0x085;
pub const TPDO1: u16 = 0x185;
pub const TPDO2: u16 = 0x285;
pub const TPDO3: u16 = 0x385;

/// Powers the roller on at t = 0 with `storage`, Operational at 10 ms, then
/// Operation enabled in pv at rest by t = 700 ms (the profile ticks every
/// millisecond from then on).
pub fn enabled_on(storage: MemStorage) -> Ec5000 {
    let mut b = Bench::new(ec5000::od::Ram::new(ID), ec5000::App::NEW, storage, ID);
    b.at(ms(0));
    b.now = ms(10);
    b.nmt(0x01, ID);
    for (t, cw) in [(100, 0x06), (300, 0x07), (500, 0x0F)] {
        b.rx(ms(t), RPDO1, &[cw, 0, 3, 0, 0, 0, 0]);
    }
    b.run_until(ms(700));
    b
}

/// [`enabled_on`] an erased storage.
pub fn enabled() -> Ec5000 {
    enabled_on(MemStorage::new(4096))
}

/// The roller behind the profile (faults are injected into its axis).
pub fn roller(b: &mut Ec5000) -> &mut Roller {
    &mut b.node.app_mut().drive.drive
}

/// The frames of the next `span` ms, with their time in ms after `from`.
pub fn frames(b: &mut Ec5000, from: u64, span: u64) -> Vec<(u64, u16, Vec<u8>)> {
    b.run_until(ms(from + span)).into_iter().map(|(at, (id, d))| (at.as_micros() / 1000 - from, id, d)).collect()
}

/// The EMCY frames of the next `span` ms, with their time in ms after `from`.
pub fn emcy(b: &mut Ec5000, from: u64, span: u64) -> Vec<(u64, Vec<u8>)> {
    frames(b, from, span).into_iter().filter(|(_, id, _)| *id == EMCY).map(|(t, _, d)| (t, d)).collect()
}

/// RPDO3 at `t` ms: controlword and target velocity [mm/s]; the frames the
/// node sends in answer (what it sent before `t` is dropped).
pub fn pv(b: &mut Ec5000, t: u64, controlword: u16, velocity: i32) -> Vec<F> {
    let [c0, c1] = controlword.to_le_bytes();
    let [v0, v1, v2, v3] = velocity.to_le_bytes();
    b.run_until(ms(t));
    b.rx(ms(t), RPDO3, &[c0, c1, v0, v1, v2, v3])
}

/// An integer value read by SDO (at most 4 bytes, sign-extended).
pub fn value(b: &mut Ec5000, index: u16, sub: u8) -> i64 {
    let v = b.sdo_upload(ID, index, sub).expect("upload");
    let mut a = [if v.last().is_some_and(|byte| byte & 0x80 != 0) { 0xFF } else { 0 }; 8];
    a[..v.len()].copy_from_slice(&v);
    i64::from_le_bytes(a)
}

/// The statusword (0x6041).
pub fn statusword(b: &mut Ec5000) -> u16 {
    value(b, 0x6041, 0) as u16
}

/// `impl Application for $name` over a wrapped `ec5000::App` (`$name.0`):
/// every hook forwarded but those a test leaves at the trait's default to
/// compare against it, which it names in `{ ... }` with its own items.
/// The hooks a test may leave out (`rpdo_written`, `rpdo_value`,
/// `POLL_WHEN_DUE`) are the items it writes there, forwarded or not.
#[allow(unused_macros)]
macro_rules! ec5000_forwarding {
    ($name:ident { $($item:item)* }) => {
        impl canopen_core::node::Application for $name {
            const OPTIONS: canopen_core::node::ServiceOptions = firmware::devices::ec5000::App::OPTIONS;
            const CAN_EMCY: canopen_core::node::CanEmcyCodes = firmware::devices::ec5000::App::CAN_EMCY;
            const STORES: bool = firmware::devices::ec5000::App::STORES;
            $($item)*
            fn upload_size(
                &mut self,
                ctx: &mut canopen_core::node::Ctx<'_>,
                index: u16,
                sub: u8,
            ) -> Option<Result<usize, canopen_core::abort::AbortCode>> {
                self.0.upload_size(ctx, index, sub)
            }
            fn read(
                &mut self,
                ctx: &mut canopen_core::node::Ctx<'_>,
                index: u16,
                sub: u8,
                offset: usize,
                buf: &mut [u8],
            ) -> Option<Result<usize, canopen_core::abort::AbortCode>> {
                self.0.read(ctx, index, sub, offset, buf)
            }
            fn download_check(
                &mut self,
                ctx: &mut canopen_core::node::Ctx<'_>,
                index: u16,
                sub: u8,
                size: Option<usize>,
            ) -> Option<Result<(), canopen_core::abort::AbortCode>> {
                self.0.download_check(ctx, index, sub, size)
            }
            fn write(
                &mut self,
                ctx: &mut canopen_core::node::Ctx<'_>,
                index: u16,
                sub: u8,
                data: &[u8],
            ) -> Option<Result<(), canopen_core::abort::AbortCode>> {
                self.0.write(ctx, index, sub, data)
            }
            fn check_write(
                &mut self,
                ctx: &canopen_core::node::Ctx<'_>,
                index: u16,
                sub: u8,
                data: &[u8],
            ) -> Result<(), canopen_core::abort::AbortCode> {
                self.0.check_write(ctx, index, sub, data)
            }
            fn written(&mut self, ctx: &mut canopen_core::node::Ctx<'_>, index: u16, sub: u8, by: canopen_core::node::Source) {
                self.0.written(ctx, index, sub, by)
            }
            fn sample(&mut self, ctx: &mut canopen_core::node::Ctx<'_>) {
                self.0.sample(ctx)
            }
            fn poll(&mut self, ctx: &mut canopen_core::node::Ctx<'_>) -> Option<canopen_core::time::Instant> {
                self.0.poll(ctx)
            }
            fn on_nmt(&mut self, ctx: &mut canopen_core::node::Ctx<'_>, event: canopen_core::node::NmtEvent) {
                self.0.on_nmt(ctx, event)
            }
            fn on_time(&mut self, ctx: &mut canopen_core::node::Ctx<'_>, time: canopen_core::wire::time_stamp::TimeOfDay) {
                self.0.on_time(ctx, time)
            }
            fn on_frame(&mut self, ctx: &mut canopen_core::node::Ctx<'_>, cob_id: u16, rtr: bool, data: &[u8]) -> bool {
                self.0.on_frame(ctx, cob_id, rtr, data)
            }
            fn claim_ids(
                &self,
                dict: &'static canopen_core::od::Dictionary,
                image: &[u8],
                claims: &mut canopen_core::node::Claims<'_>,
            ) {
                self.0.claim_ids(dict, image, claims)
            }
            fn canopen(&self) -> bool {
                self.0.canopen()
            }
        }
    };
}
#[allow(unused_imports)]
pub(crate) use ec5000_forwarding;
