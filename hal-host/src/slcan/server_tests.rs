//! The TCP server as a bus: clients see each other and the application,
//! a client that does not read costs only itself, bursts take the wire's
//! time. These tests use the wall clock (for timeouts and pacing).

use super::*;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(10);

fn std(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::standard(id, data).unwrap()
}

fn read_n(s: &mut TcpStream, n: usize) -> String {
    let mut buf = vec![0; n];
    s.read_exact(&mut buf).unwrap();
    String::from_utf8(buf).unwrap()
}

/// Bytes that arrive within `quiet` of each other, until none do.
fn read_until_quiet(s: &mut TcpStream, quiet: Duration) -> Vec<u8> {
    s.set_read_timeout(Some(quiet)).unwrap();
    let (mut out, mut buf) = (Vec::new(), [0u8; 65536]);
    loop {
        match s.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => out.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => break,
            Err(e) => panic!("{e}"),
        }
    }
    s.set_read_timeout(Some(TIMEOUT)).unwrap();
    out
}

/// A client that has opened its channel at 1 Mbit/s.
fn open_client(server: &SlcanServer) -> TcpStream {
    let mut c = TcpStream::connect(server.local_addr()).unwrap();
    c.set_read_timeout(Some(TIMEOUT)).unwrap();
    c.write_all(b"S8\rO\r").unwrap();
    assert_eq!(read_n(&mut c, 2), "\r\r");
    c
}

fn wait_for_clients(server: &SlcanServer, n: usize) {
    let start = Instant::now();
    while server.clients().len() != n {
        assert!(start.elapsed() < TIMEOUT, "{} clients, expected {n}", server.clients().len());
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn serves_one_client_after_another() {
    let (server, ch) = SlcanServer::bind("127.0.0.1:0").unwrap();
    assert!(server.clients().is_empty());
    for round in 0..2 {
        let mut c = open_client(&server);
        let st = server.clients();
        assert_eq!(st.len(), 1, "round {round}");
        assert_eq!((st[0].state, st[0].bitrate, st[0].peer), (ChannelState::Open, Some(BitRate::MBIT_1), c.local_addr().unwrap()));
        c.write_all(b"t60184000100000000000\r").unwrap();
        assert_eq!(read_n(&mut c, 2), "z\r");
        assert_eq!(ch.from_client.recv_timeout(TIMEOUT).unwrap(), std(0x601, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]));
        ch.to_client.send(std(0x581, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])).unwrap();
        assert_eq!(read_n(&mut c, 22), "t58184300100092010200\r");
        c.write_all(b"t8000\r").unwrap();
        assert_eq!(read_n(&mut c, 1), "\x07");
        assert_eq!(server.clients()[0].errors, 1);
        drop(c);
        wait_for_clients(&server, 0);
    }
    server.shutdown();
}

#[test]
fn clients_share_one_bus() {
    let (server, ch) = SlcanServer::bind("127.0.0.1:0").unwrap();
    let mut a = open_client(&server);
    let mut b = open_client(&server);
    // A third client whose channel is closed hears nothing, as an adapter.
    let mut closed = TcpStream::connect(server.local_addr()).unwrap();
    wait_for_clients(&server, 3);

    a.write_all(b"t60184000100000000000\r").unwrap();
    assert_eq!(read_n(&mut a, 2), "z\r");
    assert_eq!(ch.from_client.recv_timeout(TIMEOUT).unwrap(), std(0x601, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]));
    assert_eq!(read_n(&mut b, 22), "t60184000100000000000\r", "B sees A's request on the bus");
    ch.to_client.send(std(0x581, &[0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00])).unwrap();
    assert_eq!(read_n(&mut a, 22), "t58184300100092010200\r");
    assert_eq!(read_n(&mut b, 22), "t58184300100092010200\r");
    b.write_all(b"r7011\r").unwrap();
    assert_eq!(read_n(&mut b, 2), "z\r");
    assert_eq!(read_n(&mut a, 6), "r7011\r", "A sees B's remote frame");
    assert_eq!(ch.from_client.recv_timeout(TIMEOUT).unwrap(), CanFrame::remote(0x701, 1).unwrap());

    // Nobody gets their own frames back, and the closed channel got nothing.
    let quiet = Duration::from_millis(200);
    assert_eq!(read_until_quiet(&mut a, quiet), b"");
    assert_eq!(read_until_quiet(&mut b, quiet), b"");
    assert_eq!(read_until_quiet(&mut closed, quiet), b"");
    server.shutdown();
}

#[test]
fn a_client_that_does_not_read_loses_only_its_own_frames() {
    // A fast wire, so the flood takes little wall time.
    let options = ServerOptions { bit_rate: BitRate::new(1_000_000_000).unwrap(), client_queue_bytes: 4096, ..ServerOptions::default() };
    let (server, ch) = SlcanServer::bind_with("127.0.0.1:0", options).unwrap();
    let mut sleeper = open_client(&server);
    let mut reader = open_client(&server);
    wait_for_clients(&server, 2);
    let got = Arc::new(AtomicUsize::new(0));
    let got2 = Arc::clone(&got);
    let counter = std::thread::spawn(move || {
        let mut buf = [0u8; 65536];
        let mut lines = 0;
        while lines < FRAMES {
            let n = reader.read(&mut buf).unwrap();
            assert!(n > 0, "server closed the reading client");
            lines += buf[..n].iter().filter(|&&b| b == b'\r').count();
            got2.store(lines, Ordering::SeqCst);
        }
        reader
    });
    // 6.6 MB of frames: more than the socket buffers hold for the sleeper
    // (Linux: up to 4 MiB sent and 128 KiB received while it does not read).
    const FRAMES: usize = 300_000;
    let frame = std(0x181, &[1, 2, 3, 4, 5, 6, 7, 8]);
    let start = Instant::now();
    for sent in 1..=FRAMES {
        ch.to_client.send(frame).unwrap();
        // The reading client keeps up (its 4 KiB queue holds 186 frames);
        // only the sleeper falls behind.
        while sent % 50 == 0 && got.load(Ordering::SeqCst) + 100 < sent {
            assert!(start.elapsed() < TIMEOUT * 3, "the reading client got {} of {sent}", got.load(Ordering::SeqCst));
            std::thread::yield_now();
        }
    }
    let reader = counter.join().unwrap();
    let st = server.clients();
    assert_eq!(st[1].peer, reader.local_addr().unwrap());
    assert_eq!(st[1].dropped, 0, "the reading client lost nothing");
    assert!(st[0].dropped > 0, "the sleeping client's newest frames were dropped");
    // What waited for it (socket buffers and its 4 KiB queue) and what was
    // dropped make up every frame; its `F` command reports the data overrun.
    let backlog = read_until_quiet(&mut sleeper, Duration::from_millis(300));
    assert_eq!(backlog.len() / 22 + st[0].dropped as usize, FRAMES);
    sleeper.write_all(b"F\r").unwrap();
    assert_eq!(read_n(&mut sleeper, 4), "F08\r");
    server.shutdown();
}

#[test]
fn a_burst_takes_the_wire_time_of_its_frames() {
    let (server, ch) = SlcanServer::bind("127.0.0.1:0").unwrap();
    assert_eq!(server.bit_rate(), BitRate::MBIT_1);
    // As vnode does on LSS "activate bit timing".
    server.set_bit_rate(BitRate::KBIT_125);
    assert_eq!(server.bit_rate(), BitRate::KBIT_125);
    let mut a = open_client(&server);
    const N: usize = 100;
    let line = b"t20181122334455667788\r";
    let frame = std(0x201, &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]);
    let frame_time = Duration::from_nanos(crate::bus::frame_time_ns(&frame, BitRate::KBIT_125));
    // Timed from the write: a receiver the OS runs late finds frames waiting,
    // so the time between its first and last receive could be shorter than
    // the wire's, but the last frame cannot arrive before the wire carried all.
    let t0 = Instant::now();
    a.write_all(&line.repeat(N)).unwrap();
    for _ in 0..N {
        assert_eq!(ch.from_client.recv_timeout(TIMEOUT).unwrap(), frame);
    }
    let took = t0.elapsed();
    // 100 frames of about 1.04 ms each, at most the slack early.
    let wire = frame_time * N as u32;
    assert!(took + super::wire::SLACK >= wire, "{N} frames in {took:?}, the wire needs {wire:?}");
    // Not much slower either (the margin is for a loaded machine).
    assert!(took < wire * 3 + Duration::from_secs(2), "{N} frames in {took:?}, the wire needs {wire:?}");
    server.shutdown();
}

#[test]
fn the_application_has_bounded_room_on_a_slow_wire() {
    // 10 kbit/s: an 8-byte frame holds the wire for about 13 ms.
    let options = ServerOptions { bit_rate: BitRate::KBIT_10, app_tx_frames: 8, ..ServerOptions::default() };
    let (server, ch) = SlcanServer::bind_with("127.0.0.1:0", options).unwrap();
    let frame = std(0x181, &[1, 2, 3, 4, 5, 6, 7, 8]);
    // The refusal that ends the burst is checked, not a later try: the wire
    // frees a slot every 13 ms, which a loaded machine can let pass.
    let mut accepted = 0;
    let refused = loop {
        match ch.to_client.try_send(frame) {
            Ok(()) if accepted < 100 => accepted += 1,
            other => break other,
        }
    };
    // The 8 it has room for, and the few the wire took meanwhile.
    assert!((8..=10).contains(&accepted), "{accepted} frames accepted");
    assert!(matches!(refused, Err(mpsc::TrySendError::Full(_))));
    // Room comes back as the wire carries them.
    std::thread::sleep(Duration::from_millis(100));
    assert!(ch.to_client.try_send(frame).is_ok());
    server.shutdown();
    assert!(matches!(ch.to_client.try_send(frame), Err(mpsc::TrySendError::Disconnected(_))));
    assert!(ch.to_client.send(frame).is_err(), "a stopped server does not keep a sender waiting");
}

#[test]
fn connections_past_the_limit_are_closed_and_counted() {
    let options = ServerOptions { max_clients: 2, ..ServerOptions::default() };
    let (server, _ch) = SlcanServer::bind_with("127.0.0.1:0", options).unwrap();
    let _a = open_client(&server);
    let _b = open_client(&server);
    let mut c = TcpStream::connect(server.local_addr()).unwrap();
    c.set_read_timeout(Some(TIMEOUT)).unwrap();
    let _ = c.write_all(b"V\r");
    let mut buf = [0u8; 8];
    assert!(matches!(c.read(&mut buf), Ok(0) | Err(_)), "the third connection is closed");
    assert_eq!(server.refused(), 1);
    server.shutdown();
}

#[test]
fn the_application_sends_while_it_is_behind_with_receiving() {
    // Small queues: the wire soon waits for the application to take a
    // client's frame, while the application waits for room on the wire
    // before it takes another (as vnode does). The wire carries the
    // application's frames meanwhile, so neither waits for ever.
    let options = ServerOptions { app_queue_frames: 2, app_tx_frames: 2, ..ServerOptions::default() };
    let (server, ch) = SlcanServer::bind_with("127.0.0.1:0", options).unwrap();
    let mut c = open_client(&server);
    c.write_all(&b"t0800\r".repeat(8)).unwrap();
    assert_eq!(read_n(&mut c, 16), "z\r".repeat(8));
    // The wire holds the third frame: the application's queue is full.
    std::thread::sleep(Duration::from_millis(50));
    let (done, sent) = mpsc::channel();
    let to_client = ch.to_client.clone();
    std::thread::spawn(move || {
        let ok = (0..6u8).all(|i| to_client.send(std(0x185, &[i])).is_ok());
        let _ = done.send(ok);
    });
    assert_eq!(sent.recv_timeout(TIMEOUT), Ok(true), "the application's frames went out");
    assert_eq!(read_n(&mut c, 6 * 8), (0..6).map(|i| format!("t18510{i}\r")).collect::<String>());
    // The client's frames follow, all of them, in order.
    for _ in 0..8 {
        assert_eq!(ch.from_client.recv_timeout(TIMEOUT), Ok(std(0x080, &[])));
    }
    drop(server);
}
