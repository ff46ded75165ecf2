//! The live master against a real node: the ec5000 dictionary in
//! canopen-core's `Node`, on its own thread in real time behind the crate's
//! SLCAN server, as `vnode` runs it.

use super::*;
use crate::master::SdoClient;
use crate::slcan::{SlcanChannels, SlcanServer};
use crate::storage::MemStorage;
use canopen_core::abort::AbortCode;
use canopen_core::node::{NoApplication, Node};
use firmware::devices::ec5000::od;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};

const NODE: u8 = 5;

/// Runs node 5 from the moment `start` says so until the server goes away.
fn node_thread(channels: SlcanChannels, start: mpsc::Receiver<()>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        if start.recv().is_err() {
            return;
        }
        let t0 = Instant::now();
        let clock = || CoreInstant::from_micros(t0.elapsed().as_micros() as u64);
        let mut node: Node<_, NoApplication, MemStorage, { od::RPDO_COUNT }, { od::TPDO_COUNT }, { od::HB_CONSUMER_COUNT }> =
            Node::new(od::Ram::new(NODE), NoApplication, MemStorage::new(4096), NODE, clock());
        loop {
            node.process(clock());
            while node.resetting() {
                node.process(clock());
            }
            while let Some(frame) = node.transmit() {
                if channels.to_client.send(frame).is_err() {
                    return;
                }
            }
            match channels.from_client.recv_timeout(Duration::from_millis(5)) {
                Ok(frame) => node.on_frame(clock(), &frame),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => return,
            }
        }
    })
}

fn std_frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

#[test]
fn drives_a_node_in_real_time() {
    let (server, channels) = SlcanServer::bind("127.0.0.1:0").unwrap();
    let (go, start) = mpsc::channel();
    let node = node_thread(channels, start);
    let client = SlcanClient::connect(server.local_addr(), Duration::from_secs(5)).unwrap();
    let seen = Arc::new(Mutex::new(Vec::new()));
    let seen2 = Arc::clone(&seen);
    let observer = Box::new(move |l: &LoggedFrame| seen2.lock().unwrap().push(*l));
    let mut m = LiveMaster::open(client, observer, Duration::from_secs(5)).unwrap();
    go.send(()).unwrap();
    let long = Duration::from_secs(5);

    assert_eq!(m.wait_for(0, long, |f| f.cob_id() == Some(0x705)).unwrap(), Some(std_frame(0x705, &[0x00])));
    assert_eq!(m.sdo_upload(NODE, 0x1000, 0).unwrap(), Ok(vec![0x92, 0x01, 0x42, 0x00]));
    // Segmented: the initiate and the one segment.
    assert_eq!(m.sdo_upload(NODE, 0x1008, 0).unwrap(), Ok(b"EC5000".to_vec()));
    assert_eq!(m.sdo_upload(NODE, 0x1234, 0).unwrap(), Err(SdoClientError::ServerAbort { index: 0x1234, sub: 0, code: 0x0602_0000 }));
    assert_eq!(m.sdo_download(NODE, 0x1017, 0, &[50, 0]).unwrap(), Ok(()));
    let mark = m.mark();
    m.send_std(0x000, &[0x01, NODE]).unwrap();
    let hb = m.wait_for(mark, long, |f| f.cob_id() == Some(0x705)).unwrap();
    assert_eq!(hb, Some(std_frame(0x705, &[0x05])));
    // A frame logged during a transfer is found by a later wait.
    let mark = m.mark();
    assert_eq!(m.sdo_upload(NODE, 0x1017, 0).unwrap(), Ok(vec![50, 0]));
    m.idle(Duration::from_millis(120)).unwrap();
    let before = m.mark();
    assert_eq!(m.wait_for(mark, Duration::ZERO, |f| f.cob_id() == Some(0x705)).unwrap(), Some(std_frame(0x705, &[0x05])));
    assert_eq!(m.mark(), before, "found in the log, nothing read");

    // The log: requests and answers in order, times rising, the observer saw the same.
    let log = m.log().to_vec();
    let sent: Vec<_> = log.iter().filter(|l| l.direction == Direction::Sent).map(|l| l.frame).collect();
    assert_eq!(sent[0], std_frame(0x605, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]));
    assert_eq!(sent[1], std_frame(0x605, &[0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0]));
    assert_eq!(sent[2], std_frame(0x605, &[0x60, 0, 0, 0, 0, 0, 0, 0]), "upload segment request, toggle 0");
    assert_eq!(sent[5], std_frame(0x000, &[0x01, NODE]));
    assert!(log.windows(2).all(|w| w[0].at <= w[1].at));
    assert_eq!(*seen.lock().unwrap(), log);
    m.idle(Duration::from_millis(50)).unwrap();
    assert_eq!(m.counts(), AdapterCounts { acks: sent.len() as u64, refused: 0, garbage: 0 });
    drop(m);
    drop(server);
    node.join().unwrap();
}

#[test]
fn a_silent_server_times_out_with_an_abort() {
    let (server, _channels) = SlcanServer::bind("127.0.0.1:0").unwrap();
    let client = SlcanClient::connect(server.local_addr(), Duration::from_secs(5)).unwrap();
    let mut m = LiveMaster::open(client, Box::new(|_| {}), Duration::from_secs(5)).unwrap();
    let mut sdo = SdoClient::new(9);
    sdo.timeout = canopen_core::time::Duration::from_millis(100);
    let start = Instant::now();
    let result = m.run_transfer(sdo.upload(m.now(), 0x1000, 0, UploadMode::ExpeditedOrSegmented)).unwrap();
    assert_eq!(result, Err(SdoClientError::Timeout));
    assert!(start.elapsed() >= Duration::from_millis(100));
    let abort = AbortCode::Timeout.code().to_le_bytes();
    let sent: Vec<_> = m.log().iter().map(|l| (l.direction, l.frame)).collect();
    assert_eq!(
        sent,
        [
            (Direction::Sent, std_frame(0x609, &[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0])),
            (Direction::Sent, std_frame(0x609, &[0x80, 0x00, 0x10, 0x00, abort[0], abort[1], abort[2], abort[3]])),
        ]
    );
}
