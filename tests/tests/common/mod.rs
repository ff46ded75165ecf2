//! Test bench for one node driven directly: frames in at exact times, the
//! exact frames out, then nothing else.
#![allow(dead_code)]

pub mod bmaxx4400;
pub mod ec5000;
pub mod net;
pub mod sendix;

use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use embedded_can::Frame;

/// `struct $name($ram)`: the dictionary `$ram` with other services than its
/// EDS chose (`Services { $field: $value, .. }`), as a device whose EDS
/// chose them would be built.
// Not every test binary that includes `common` builds such a dictionary.
#[allow(unused_macros)]
macro_rules! with_services {
    ($(#[$meta:meta])* $name:ident($ram:ty) { $($field:ident: $value:expr),* $(,)? }) => {
        $(#[$meta])*
        struct $name($ram);

        impl canopen_core::od::ObjectDictionary for $name {
            const SERVICES: canopen_core::od::Services = canopen_core::od::Services {
                $($field: $value,)*
                ..<$ram as canopen_core::od::ObjectDictionary>::SERVICES
            };
            fn dictionary(&self) -> &'static canopen_core::od::Dictionary {
                canopen_core::od::ObjectDictionary::dictionary(&self.0)
            }
            fn image(&self) -> &[u8] {
                canopen_core::od::ObjectDictionary::image(&self.0)
            }
            fn image_mut(&mut self) -> &mut [u8] {
                canopen_core::od::ObjectDictionary::image_mut(&mut self.0)
            }
        }
    };
}
#[allow(unused_imports)]
pub(crate) use with_services;

/// A frame as tests write it: COB-ID and data.
pub type F = (u16, Vec<u8>);

/// A node, its clock, and what it sent.
pub struct Bench<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize> {
    /// The node under test.
    pub node: Node<O, A, S, R, T, HB>,
    /// Virtual time.
    pub now: Instant,
}

/// Milliseconds as an instant.
pub fn ms(t: u64) -> Instant {
    Instant::from_micros(t * 1000)
}

impl<O: ObjectDictionary, A: Application, S: Storage, const R: usize, const T: usize, const HB: usize> Bench<O, A, S, R, T, HB> {
    /// Powers a node on at t = 0.
    pub fn new(od: O, app: A, storage: S, node_id: u8) -> Self {
        Bench { node: Node::new(od, app, storage, node_id, Instant::ZERO), now: Instant::ZERO }
    }

    /// Runs the node at `t` and returns every frame it sends.
    pub fn at(&mut self, t: Instant) -> Vec<F> {
        assert!(t >= self.now, "time runs forward");
        self.now = t;
        self.node.process(t);
        // A reset goes on a stage per call until the boot-up is queued, a store until its answer is.
        while self.node.resetting() || self.node.storing() {
            self.node.process(t);
        }
        self.drain()
    }

    fn drain(&mut self) -> Vec<F> {
        let mut out = Vec::new();
        while let Some(f) = self.node.transmit() {
            out.push((f.cob_id().expect("11-bit"), f.data().to_vec()));
        }
        out
    }

    /// Delivers a frame at `t`, runs the node, returns what it sends.
    pub fn rx(&mut self, t: Instant, cob_id: u16, data: &[u8]) -> Vec<F> {
        self.now = t;
        self.node.on_frame(t, &CanFrame::standard(cob_id, data).expect("valid frame"));
        self.at(t)
    }

    /// Delivers a remote frame at `t`.
    pub fn rtr(&mut self, t: Instant, cob_id: u16) -> Vec<F> {
        self.now = t;
        self.node.on_frame(t, &CanFrame::remote(cob_id, 1).expect("valid frame"));
        self.at(t)
    }

    /// Runs every deadline up to `t` in order, collecting (time, frame).
    pub fn run_until(&mut self, t: Instant) -> Vec<(Instant, F)> {
        let mut out = Vec::new();
        loop {
            let next = self.node.process(self.now);
            out.extend(self.drain().into_iter().map(|f| (self.now, f)));
            match next {
                Some(d) if d <= t && d > self.now => self.now = d,
                Some(d) if d <= self.now => continue,
                _ => break,
            }
        }
        self.now = t;
        self.node.process(t);
        out.extend(self.drain().into_iter().map(|f| (t, f)));
        out
    }

    /// Maps `entries` into PDO mapping `index` of node `id` by SDO, as a PLC
    /// does: sub 0 = 0, the entries, then sub 0 = their number; each accepted.
    pub fn map_pdo(&mut self, id: u8, index: u16, entries: &[u32]) {
        assert_eq!(self.sdo_write(id, index, 0, &[0]), ok_write(index, 0));
        for (sub, e) in (1..).zip(entries) {
            assert_eq!(self.sdo_write(id, index, sub, &e.to_le_bytes()), ok_write(index, sub));
        }
        assert_eq!(self.sdo_write(id, index, 0, &[entries.len() as u8]), ok_write(index, 0));
    }

    /// An expedited SDO download of `data` to (index, sub) on node `id`; returns the answer.
    pub fn sdo_write(&mut self, id: u8, index: u16, sub: u8, data: &[u8]) -> Vec<u8> {
        let out = self.rx(self.now, 0x600 + u16::from(id), &expedited_download(index, sub, data));
        assert_eq!(out.len(), 1, "one answer: {out:x?}");
        assert_eq!(out[0].0, 0x580 + u16::from(id));
        out[0].1.clone()
    }

    /// Sends one SDO request to server `rx` and returns its one answer on `tx`.
    fn sdo_exchange(&mut self, rx: u16, tx: u16, req: [u8; 8]) -> [u8; 8] {
        let out = self.rx(self.now, rx, &req);
        assert_eq!(out.len(), 1, "one answer to {req:02x?}: {out:x?}");
        assert_eq!(out[0].0, tx, "answer on the server's tx COB-ID");
        out[0].1.clone().try_into().expect("8-byte SDO frame")
    }

    /// A complete SDO upload from the server on (`rx`, `tx`), expedited or
    /// segmented as the server chooses; the value, or the abort code.
    pub fn sdo_upload_via(&mut self, rx: u16, tx: u16, index: u16, sub: u8) -> Result<Vec<u8>, u32> {
        let [lo, hi] = index.to_le_bytes();
        let r = self.sdo_exchange(rx, tx, [0x40, lo, hi, sub, 0, 0, 0, 0]);
        match r[0] {
            0x80 => Err(u32::from_le_bytes([r[4], r[5], r[6], r[7]])),
            c if c & 0xE2 == 0x42 => {
                // Expedited: 4 − n bytes when s = 1, else 4.
                let n = if c & 0x01 != 0 { 4 - usize::from((c >> 2) & 3) } else { 4 };
                Ok(r[4..4 + n].to_vec())
            }
            c if c & 0xE2 == 0x40 => {
                let size = (c & 0x01 != 0).then(|| u32::from_le_bytes([r[4], r[5], r[6], r[7]]) as usize);
                let mut value = Vec::new();
                let mut toggle = 0u8;
                loop {
                    let s = self.sdo_exchange(rx, tx, [0x60 | toggle, 0, 0, 0, 0, 0, 0, 0]);
                    if s[0] == 0x80 {
                        return Err(u32::from_le_bytes([s[4], s[5], s[6], s[7]]));
                    }
                    assert_eq!(s[0] & 0xF0, toggle, "upload segment toggle: {s:02x?}");
                    let n = 7 - usize::from((s[0] >> 1) & 7);
                    value.extend_from_slice(&s[1..1 + n]);
                    if s[0] & 1 != 0 {
                        break;
                    }
                    toggle ^= 0x10;
                }
                if let Some(size) = size {
                    assert_eq!(value.len(), size, "segmented upload size");
                }
                Ok(value)
            }
            _ => panic!("not an initiate upload response: {r:02x?}"),
        }
    }

    /// [`Bench::sdo_upload_via`] on the default server of node `id`.
    pub fn sdo_upload(&mut self, id: u8, index: u16, sub: u8) -> Result<Vec<u8>, u32> {
        self.sdo_upload_via(0x600 + u16::from(id), 0x580 + u16::from(id), index, sub)
    }

    /// A complete SDO download to the server on (`rx`, `tx`): expedited for
    /// 1 to 4 bytes, else segmented with the size indicated; Ok, or the abort code.
    pub fn sdo_download_via(&mut self, rx: u16, tx: u16, index: u16, sub: u8, data: &[u8]) -> Result<(), u32> {
        let [lo, hi] = index.to_le_bytes();
        let abort = |r: [u8; 8]| Err(u32::from_le_bytes([r[4], r[5], r[6], r[7]]));
        if (1..=4).contains(&data.len()) {
            let mut req = [0x23 | (((4 - data.len()) as u8) << 2), lo, hi, sub, 0, 0, 0, 0];
            req[4..4 + data.len()].copy_from_slice(data);
            let r = self.sdo_exchange(rx, tx, req);
            if r[0] == 0x80 {
                return abort(r);
            }
            assert_eq!(r, [0x60, lo, hi, sub, 0, 0, 0, 0]);
            return Ok(());
        }
        let [a, b, c, d] = (data.len() as u32).to_le_bytes();
        let r = self.sdo_exchange(rx, tx, [0x21, lo, hi, sub, a, b, c, d]);
        if r[0] == 0x80 {
            return abort(r);
        }
        assert_eq!(r, [0x60, lo, hi, sub, 0, 0, 0, 0]);
        let mut toggle = 0u8;
        if data.is_empty() {
            let r = self.sdo_exchange(rx, tx, [0x0F, 0, 0, 0, 0, 0, 0, 0]);
            if r[0] == 0x80 {
                return abort(r);
            }
            assert_eq!(r, [0x20, 0, 0, 0, 0, 0, 0, 0]);
            return Ok(());
        }
        let mut chunks = data.chunks(7).peekable();
        while let Some(chunk) = chunks.next() {
            let last = chunks.peek().is_none();
            let mut req = [toggle | (((7 - chunk.len()) as u8) << 1) | u8::from(last), 0, 0, 0, 0, 0, 0, 0];
            req[1..1 + chunk.len()].copy_from_slice(chunk);
            let r = self.sdo_exchange(rx, tx, req);
            if r[0] == 0x80 {
                return abort(r);
            }
            assert_eq!(r, [0x20 | toggle, 0, 0, 0, 0, 0, 0, 0], "download segment response");
            toggle ^= 0x10;
        }
        Ok(())
    }

    /// [`Bench::sdo_download_via`] on the default server of node `id`.
    pub fn sdo_download(&mut self, id: u8, index: u16, sub: u8, data: &[u8]) -> Result<(), u32> {
        self.sdo_download_via(0x600 + u16::from(id), 0x580 + u16::from(id), index, sub, data)
    }

    /// An NMT command (`cs`) to `id` (0: all) at the bench's time; returns what the node sends.
    pub fn nmt(&mut self, cs: u8, id: u8) -> Vec<F> {
        self.rx(self.now, 0x000, &[cs, id])
    }

    /// An expedited SDO upload; returns the answer.
    pub fn sdo_read(&mut self, id: u8, index: u16, sub: u8) -> Vec<u8> {
        let [lo, hi] = index.to_le_bytes();
        let out = self.rx(self.now, 0x600 + u16::from(id), &[0x40, lo, hi, sub, 0, 0, 0, 0]);
        assert_eq!(out.len(), 1, "one answer: {out:x?}");
        out[0].1.clone()
    }
}

/// The expedited SDO download request of `data` (1 to 4 bytes) to (index, sub).
pub fn expedited_download(index: u16, sub: u8, data: &[u8]) -> [u8; 8] {
    let n = data.len();
    assert!((1..=4).contains(&n));
    let mut req = [0u8; 8];
    req[0] = 0x23 | (((4 - n) as u8) << 2);
    req[1..3].copy_from_slice(&index.to_le_bytes());
    req[3] = sub;
    req[4..4 + n].copy_from_slice(data);
    req
}

/// The SDO download confirmation for (index, sub).
pub fn ok_write(index: u16, sub: u8) -> Vec<u8> {
    let [lo, hi] = index.to_le_bytes();
    vec![0x60, lo, hi, sub, 0, 0, 0, 0]
}

/// An SDO abort frame for (index, sub).
pub fn abort(index: u16, sub: u8, code: u32) -> Vec<u8> {
    let [lo, hi] = index.to_le_bytes();
    let [a, b, c, d] = code.to_le_bytes();
    vec![0x80, lo, hi, sub, a, b, c, d]
}
