//! Test bench for one node driven directly: frames in at exact times, the
//! exact frames out, then nothing else.
#![allow(dead_code)]

use canopen_core::frame::CanFrame;
use canopen_core::node::{Application, Node};
use canopen_core::od::ObjectDictionary;
use canopen_core::storage::Storage;
use canopen_core::time::Instant;
use embedded_can::Frame;

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

    /// An expedited SDO download of `data` to (index, sub) on node `id`; returns the answer.
    pub fn sdo_write(&mut self, id: u8, index: u16, sub: u8, data: &[u8]) -> Vec<u8> {
        let n = data.len();
        assert!((1..=4).contains(&n));
        let mut req = [0u8; 8];
        req[0] = 0x23 | (((4 - n) as u8) << 2);
        req[1..3].copy_from_slice(&index.to_le_bytes());
        req[3] = sub;
        req[4..4 + n].copy_from_slice(data);
        let out = self.rx(self.now, 0x600 + u16::from(id), &req);
        assert_eq!(out.len(), 1, "one answer: {out:x?}");
        assert_eq!(out[0].0, 0x580 + u16::from(id));
        out[0].1.clone()
    }

    /// An expedited SDO upload; returns the answer.
    pub fn sdo_read(&mut self, id: u8, index: u16, sub: u8) -> Vec<u8> {
        let [lo, hi] = index.to_le_bytes();
        let out = self.rx(self.now, 0x600 + u16::from(id), &[0x40, lo, hi, sub, 0, 0, 0, 0]);
        assert_eq!(out.len(), 1, "one answer: {out:x?}");
        out[0].1.clone()
    }
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
