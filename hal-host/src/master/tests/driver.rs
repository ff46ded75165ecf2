//! The bus driver against the core's SDO server on the virtual bus.

use super::NODE;
use crate::bus::{BitRate, Bus, PortId};
use crate::master::{DownloadMode, Network, SdoClientError, UploadMode, sdo_download, sdo_upload, send};
use canopen_core::abort::AbortCode;
use canopen_core::frame::CanFrame;
use canopen_core::od::ObjectAccess;
use canopen_core::services::sdo_server::{SdoServer, SdoTx};
use canopen_core::time::{Duration, Instant};
use embedded_can::Frame;
use std::collections::BTreeMap;

/// A dictionary of byte strings; downloads replace values of existing entries.
struct MemOd(BTreeMap<(u16, u8), Vec<u8>>);

impl ObjectAccess for MemOd {
    fn upload_size(&mut self, index: u16, sub: u8) -> Result<usize, AbortCode> {
        self.0.get(&(index, sub)).map(Vec::len).ok_or(AbortCode::NoObject)
    }

    fn read(&mut self, index: u16, sub: u8, offset: usize, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let rest = self.0.get(&(index, sub)).ok_or(AbortCode::NoObject)?.get(offset..).unwrap_or(&[]);
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        Ok(n)
    }

    fn download_check(&mut self, index: u16, sub: u8, _size: Option<usize>) -> Result<(), AbortCode> {
        if self.0.contains_key(&(index, sub)) { Ok(()) } else { Err(AbortCode::NoObject) }
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        self.0.insert((index, sub), data.to_vec());
        Ok(())
    }
}

struct Frames(Vec<[u8; 8]>);

impl SdoTx for Frames {
    fn send(&mut self, data: [u8; 8]) -> bool {
        self.0.push(data);
        true
    }
}

/// The bus's time as the server, which runs without a node, takes it: its
/// epoch is the bus's start (these tests run for seconds, below 2^31 µs).
fn server_time(t: Instant) -> canopen_core::time::At {
    canopen_core::time::At::try_from(t.as_micros()).expect("below 2^31 µs")
}

/// The bus, and node 5's SDO server on its own port.
struct World {
    bus: Bus,
    port: PortId,
    server: SdoServer<512>,
    od: MemOd,
    unclaimed: Vec<(Instant, CanFrame)>,
}

impl Network for World {
    fn bus(&mut self) -> &mut Bus {
        &mut self.bus
    }

    fn poll(&mut self, now: Instant) -> Option<Instant> {
        let mut out = Frames(Vec::new());
        while let Some((at, f)) = self.bus.recv(self.port) {
            if f.cob_id() == Some(0x600 + u16::from(NODE)) {
                self.server.on_request(server_time(at), f.data(), &mut self.od, &mut out);
            }
        }
        let next = self.server.poll(server_time(now), &mut self.od, &mut out).map(|t| Instant::from_micros(u64::from(t)));
        for data in out.0 {
            send(&mut self.bus, self.port, 0x580 + u16::from(NODE), &data).unwrap();
        }
        next
    }

    fn unclaimed(&mut self, at: Instant, frame: &CanFrame) {
        self.unclaimed.push((at, *frame));
    }
}

/// The world and the master's port.
fn world() -> (World, PortId) {
    let mut bus = Bus::new(BitRate::KBIT_500);
    let master = bus.attach();
    let port = bus.attach();
    bus.enable_trace();
    let od = MemOd([((0x1000, 0), vec![0x92, 0x01, 0x02, 0x00]), ((0x2000, 0), Vec::new())].into());
    (World { bus, port, server: SdoServer::new(), od, unclaimed: Vec::new() }, master)
}

fn big() -> Vec<u8> {
    (0..200u32).map(|i| (i * 7) as u8).collect()
}

#[test]
fn every_transfer_type_against_the_core_server() {
    let (mut w, m) = world();
    assert_eq!(sdo_upload(&mut w, m, NODE, 0x1000, 0, UploadMode::ExpeditedOrSegmented), Ok(vec![0x92, 0x01, 0x02, 0x00]));
    let value = big();
    let uploads = [
        UploadMode::ExpeditedOrSegmented,
        UploadMode::Block { blksize: 7, pst: 0, crc: true },
        UploadMode::Block { blksize: 127, pst: 0, crc: false },
    ];
    for mode in [DownloadMode::Auto, DownloadMode::Segmented, DownloadMode::Block { crc: true }, DownloadMode::Block { crc: false }] {
        w.od.0.insert((0x2000, 0), Vec::new());
        assert_eq!(sdo_download(&mut w, m, NODE, 0x2000, 0, &value, mode), Ok(()), "{mode:?}");
        assert_eq!(w.od.0[&(0x2000, 0)], value, "{mode:?}");
        // The driver returns once the server has seen the last frame.
        assert!(w.server.is_idle());
        for up in uploads {
            assert_eq!(sdo_upload(&mut w, m, NODE, 0x2000, 0, up).as_deref(), Ok(&value[..]), "{up:?}");
            assert!(w.server.is_idle());
        }
    }
    // Expedited both ways, and a block upload the server switches to expedited (pst).
    assert_eq!(sdo_download(&mut w, m, NODE, 0x2000, 0, &[1, 2, 3], DownloadMode::Expedited), Ok(()));
    let pst = UploadMode::Block { blksize: 127, pst: 10, crc: true };
    assert_eq!(sdo_upload(&mut w, m, NODE, 0x2000, 0, pst), Ok(vec![1, 2, 3]));
    assert!(w.unclaimed.is_empty());
}

#[test]
fn silent_node_times_out_on_virtual_time() {
    let mut bus = Bus::new(BitRate::KBIT_500);
    let (m, listener) = (bus.attach(), bus.attach());
    assert_eq!(sdo_upload(&mut bus, m, NODE, 0x1000, 0, UploadMode::ExpeditedOrSegmented), Err(SdoClientError::Timeout));
    let seen: Vec<_> = std::iter::from_fn(|| bus.recv(listener)).map(|(t, f)| (t, f.cob_id(), f.data().to_vec())).collect();
    assert_eq!(seen.len(), 2);
    assert_eq!((seen[0].1, &seen[0].2[..]), (Some(0x605), &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0][..]));
    assert_eq!((seen[1].1, &seen[1].2[..]), (Some(0x605), &[0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05][..]));
    // The wait starts when the request has left; the abort takes one frame time.
    let waited = seen[1].0.saturating_duration_since(seen[0].0);
    assert!(waited > Duration::from_secs(1) && waited < Duration::from_secs(1) + Duration::from_millis(1), "{waited:?}");
}

#[test]
fn lost_block_upload_segment_is_recovered() {
    let (mut w, m) = world();
    w.od.0.insert((0x2000, 0), big());
    let server = w.port;
    let mut dropped = false;
    w.bus.drop_where(move |p, f| {
        let hit = !dropped && p == server && f.data().first() == Some(&0x03);
        dropped |= hit;
        hit
    });
    let mode = UploadMode::Block { blksize: 8, pst: 0, crc: true };
    assert_eq!(sdo_upload(&mut w, m, NODE, 0x2000, 0, mode), Ok(big()));
    // The first sub-block was acknowledged up to segment 2.
    assert!(w.bus.trace().iter().any(|e| e.port == m && e.frame.data() == [0xA2, 2, 8, 0, 0, 0, 0, 0]));
    assert!(w.server.is_idle());
}

#[test]
fn lost_block_download_segment_is_sent_again() {
    let (mut w, m) = world();
    let master = m;
    let mut dropped = false;
    w.bus.drop_where(move |p, f| {
        let hit = !dropped && p == master && f.data().first() == Some(&0x02);
        dropped |= hit;
        hit
    });
    assert_eq!(sdo_download(&mut w, m, NODE, 0x2000, 0, &big(), DownloadMode::Block { crc: true }), Ok(()));
    assert_eq!(w.od.0[&(0x2000, 0)], big());
    assert!(w.bus.trace().iter().any(|e| e.port == w.port && e.frame.data().first() == Some(&0xA2) && e.frame.data()[1] == 1));
}

#[test]
fn server_aborts_and_other_frames_reach_the_test() {
    let (mut w, m) = world();
    let port = w.port;
    send(&mut w.bus, port, 0x705, &[0x05]).unwrap();
    let r = sdo_upload(&mut w, m, NODE, 0x3000, 0, UploadMode::Block { blksize: 4, pst: 0, crc: true });
    assert_eq!(r, Err(SdoClientError::ServerAbort { index: 0x3000, sub: 0, code: 0x0602_0000 }));
    assert_eq!(r.unwrap_err().abort_code(), Some(AbortCode::NoObject));
    assert_eq!(w.unclaimed.len(), 1);
    assert_eq!((w.unclaimed[0].1.cob_id(), w.unclaimed[0].1.data()), (Some(0x705), &[0x05][..]));
}
