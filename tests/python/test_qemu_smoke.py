"""QEMU smoke tests: python-canopen (an independent CANopen master) drives each
device's firmware image as it runs on the emulated lm3s6965evb, over SLCAN on
the emulated UART (docs/firmware.md).

Run through `cargo xtask smoke`, which builds the images and sets QEMU_SMOKE=1:
    QEMU_SMOKE=1 .venv/bin/python -m unittest -v tests/python/test_qemu_smoke.py
Each image runs under a hard timeout and must end through the firmware's
semihosting exit (the 29-bit frame 0x1FFFFFFF "EXIT") with exit code 0. At
the exit frame the board reports on QEMU's stderr how much stack it used at
start-up and since (painted at reset and again after start-up, scanned at
exit); `cargo xtask smoke` passes each image's static estimates of both in
QEMU_STACK_BOUNDS, and the measured figures must stay below them.
"""

import os
import re
import socket
import struct
import subprocess
import sys
import threading
import time
import unittest

import can
import canopen
from canopen.profiles.p402 import BaseNode402

# The shared UNITEK session sits next to this file, which also runs as `-m unittest <path>`.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import unitek  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TARGET_DIR = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
RELEASE = os.path.join(TARGET_DIR, "thumbv7m-none-eabi", "release")
LOGS = os.path.join(TARGET_DIR, "qemu-smoke")

# Device -> node-id the image starts with (firmware/src/devices/*.rs, from each manual).
DEVICES = {"ec5000": 127, "unitek-ds": 1, "sendix": 0x3F, "bmaxx4400": 1, "agile": 1}
# Images that run the CiA 402 profile with the axis model.
CIA402 = {"ec5000"}

STACK_LINE = re.compile(r"stack: start-up (\d+) bytes, running (\d+) bytes of (\d+)")
FILTER_LINE = re.compile(r"; filter rejected (\d+) frames, lost (\d+)$")
# Stack (bytes) an image may use when run without `cargo xtask smoke` (which
# passes each image's static estimates): the most any image measured (10,692
# bytes, bmaxx4400 at start-up) with 15 % to spare.
DEFAULT_STACK_BOUND = 12 * 1024
RUN_TIMEOUT = 90.0  # seconds of wall time per image, then QEMU is killed
WAIT = 5.0  # seconds to wait for one expected frame
ROUND_TRIP = 0.02  # seconds: median expedited SDO round trip (about 2 ms measured at load average 7)
EXIT_ID = 0x1FFFFFFF
NO_OBJECT = 0x06020000
NO_SUB_INDEX = 0x06090011
OPERATIONAL = 0x05
SIGNED = (0x02, 0x03, 0x04, 0x15)  # INTEGER8/16/32/64 (CiA 301 table 44)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class FrameLog(can.Listener):
    """Every frame the node sent, in order, for waits on exact frames."""

    def __init__(self):
        self.frames = []
        self.cond = threading.Condition()

    def on_message_received(self, msg):
        with self.cond:
            self.frames.append(msg)
            self.cond.notify_all()

    def mark(self):
        with self.cond:
            return len(self.frames)

    def wait_for(self, pred, after=0, timeout=WAIT):
        """The first frame from position `after` on that satisfies `pred`."""
        end = time.monotonic() + timeout
        with self.cond:
            while True:
                for msg in self.frames[after:]:
                    if pred(msg):
                        return msg
                left = end - time.monotonic()
                if left <= 0:
                    return None
                self.cond.wait(left)

    def since(self, after, cob_id):
        with self.cond:
            return [m for m in self.frames[after:] if m.arbitration_id == cob_id and not m.is_extended_id]


class QemuImage:
    """One image in QEMU, its UART as a TCP server; the test is the only client."""

    def __init__(self, device):
        self.device = device
        self.elf = os.path.join(RELEASE, f"{device}-qemu")
        if not os.path.exists(self.elf):
            raise unittest.SkipTest(f"{self.elf} missing: run `cargo xtask build` or `cargo xtask smoke`")
        os.makedirs(LOGS, exist_ok=True)
        self.network = None
        self.bus = None
        self.port = free_port()
        self.log = open(os.path.join(LOGS, f"{device}.defmt"), "wb")
        self.proc = subprocess.Popen(
            ["qemu-system-arm", "-M", "lm3s6965evb", "-cpu", "cortex-m3", "-display", "none", "-monitor", "none",
             "-semihosting-config", "enable=on,target=native", "-icount", "shift=4,align=off,sleep=on",
             "-serial", f"tcp:127.0.0.1:{self.port},server=on,wait=on,nodelay=on", "-kernel", self.elf],
            stdout=self.log, stderr=subprocess.PIPE, text=True)
        self.killer = threading.Timer(RUN_TIMEOUT, self.proc.kill)
        self.killer.start()
        self.stderr = []
        listening = threading.Event()
        self.reader = threading.Thread(target=self._read_stderr, args=(listening,), daemon=True)
        self.reader.start()
        if not listening.wait(WAIT):
            self.close()
            raise AssertionError(f"QEMU did not open tcp:{self.port}: {''.join(self.stderr)}")
        self.bus = can.Bus(interface="slcan", channel=f"socket://127.0.0.1:{self.port}", bitrate=500000,
                           sleep_after_open=0)

    def _read_stderr(self, listening):
        for line in self.proc.stderr:
            self.stderr.append(line)
            if "waiting for connection" in line:
                listening.set()

    def exit(self, status=0):
        """Ends the run through the firmware's semihosting exit; returns QEMU's exit code."""
        # Stop reading first: the socket closes when QEMU exits.
        self.network.notifier.stop()
        self.network.send_message(EXIT_ID, b"EXIT" + bytes([status]))
        try:
            return self.proc.wait(WAIT)
        except subprocess.TimeoutExpired:
            return None

    def close(self):
        self.killer.cancel()
        bus = self.bus
        # pyserial skips closing a socket whose shutdown failed (the peer is
        # gone): keep a reference to close it below.
        sock = getattr(getattr(bus, "serialPortOrig", None), "_socket", None)
        try:
            if self.network is not None:
                self.network.disconnect()
            elif bus is not None:
                bus.shutdown()
        except can.CanError:
            pass  # the socket went away with QEMU before the adapter's `C`
        if sock is not None:
            sock.close()
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self.reader.join(WAIT)
        self.proc.stderr.close()
        self.log.close()


class QemuSmokeTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if not os.environ.get("QEMU_SMOKE"):
            raise unittest.SkipTest("run through `cargo xtask smoke` (or set QEMU_SMOKE=1)")

    def run_device(self, device):
        node_id = DEVICES[device]
        od = canopen.import_od(os.path.join(ROOT, "firmware", "eds", f"{device}.eds"), node_id)
        q = QemuImage(device)
        try:
            if device == "unitek-ds":
                rejected = self.check_unitek(q)
            else:
                rejected = self.check_device(q, device, node_id, od)
        except BaseException:
            print(f"\n{device}: QEMU stderr: {''.join(q.stderr)}")
            raise
        finally:
            q.close()
        self.check_rejected(q, rejected)
        self.check_stack(q)

    def check_stack(self, q):
        """The stack the image used at start-up and while running stays
        below its bounds: the static estimates, which this checks as upper
        bounds."""
        found = [STACK_LINE.search(line) for line in q.stderr]
        found = [m for m in found if m]
        self.assertEqual(len(found), 1, f"one stack report on stderr: {''.join(q.stderr)}")
        startup, running, size = (int(g) for g in found[0].groups())
        bounds = dict(item.split("=") for item in os.environ.get("QEMU_STACK_BOUNDS", "").split(",") if item)
        bound = bounds.get(q.device, f"{DEFAULT_STACK_BOUND}/{DEFAULT_STACK_BOUND}")
        startup_bound, running_bound = (int(b) for b in bound.split("/"))
        print(f"\n{q.device}: stack start-up {startup} B (bound {startup_bound}), running {running} B (bound {running_bound}),"
              f" {size} B painted")
        # Both runs of the paint were used: the node's construction, and the tasks and handlers.
        self.assertGreater(startup, 0, "start-up figure")
        self.assertGreater(running, 0, "running figure")
        self.assertLess(max(startup, running), size, "the paint was not used up")
        self.assertLessEqual(startup, startup_bound, "start-up stack over its bound")
        self.assertLessEqual(running, running_bound, "running stack over its bound")

    def check_rejected(self, q, expected):
        """The board's software acceptance filter dropped exactly the frames
        sent to identifiers the node does not consume, and no received frame
        was lost: the counts the board writes to QEMU's stderr at the exit
        frame."""
        found = [FILTER_LINE.search(line) for line in q.stderr]
        found = [m.groups() for m in found if m]
        self.assertEqual(found, [(str(expected), "0")], f"filter report on stderr: {''.join(q.stderr)}")

    def check_unitek(self, q):
        """The UNITEK DS is no CANopen node: no boot-up, and its register
        protocol (python-can, tests/python/unitek.py) owns the bus."""
        self.assertIsNone(q.bus.recv(0.5), "the UNITEK drive sends no boot-up")
        frames = FrameLog()
        q.network = canopen.Network(q.bus)
        q.network.listeners.append(frames)
        q.network.connect()
        # The guest's clock counts instructions (-icount): its 10 ms take 12-30 ms
        # of wall time on an idle host and more on a busy one, so the wall-time
        # bounds (0.5-10 x) catch a wrong period, not jitter;
        # in the guest's own time every period must be exact.
        rejected = unitek.session(self, q.network.send_message, frames, wall_period=(0.005, 0.1), strict=True)
        self.assertEqual(q.exit(0), 0, "QEMU exit code")
        return rejected

    def check_device(self, q, device, node_id, od):
        # ---- boot-up: the first frame, before anything was asked ----------
        first = q.bus.recv(WAIT)
        self.assertIsNotNone(first, "no boot-up frame")
        self.assertEqual((first.arbitration_id, bytes(first.data)), (0x700 + node_id, b"\x00"), "boot-up")

        frames = FrameLog()
        q.network = canopen.Network(q.bus)
        q.network.listeners.append(frames)
        q.network.connect()
        # The drives as a PLC drives them: python-canopen's CiA 402 node.
        node = BaseNode402(node_id, od) if device in CIA402 else canopen.RemoteNode(node_id, od)
        q.network.add_node(node)
        node.sdo.RESPONSE_TIMEOUT = 2.0
        sdo_tx = 0x580 + node_id

        def upload(index, sub=0):
            return node.sdo.upload(index, sub)

        def u(index, sub=0):
            return int.from_bytes(upload(index, sub), "little")

        # ---- SDO: identity ------------------------------------------------
        self.assertEqual(u(0x1000), od[0x1000].default, "0x1000 device type")
        identity = od[0x1018]
        self.assertEqual(u(0x1018, 0), identity[0].default)
        for sub in range(1, identity[0].default + 1):
            if sub in identity:
                self.assertEqual(u(0x1018, sub), identity[sub].default, f"0x1018 sub {sub}")

        # ---- SDO: segmented upload of 0x1008 ------------------------------
        if 0x1008 in od:
            mark = frames.mark()
            name = upload(0x1008)
            self.assertEqual(name.decode("latin-1"), od[0x1008].default)
            self.assertGreater(len(name), 4, "too short to need a segmented transfer")
            init = frames.wait_for(lambda m: m.arbitration_id == sdo_tx, after=mark)
            self.assertEqual(init.data[0] & 0xE2, 0x40, f"initiate upload response {bytes(init.data).hex()} is not segmented")
            segments = [m for m in frames.since(mark, sdo_tx)[1:] if m.data[0] & 0xE0 == 0x00]
            self.assertEqual(len(segments), (len(name) + 6) // 7)
        else:
            with self.assertRaises(canopen.SdoAbortedError) as e:
                upload(0x1008)
            self.assertEqual(e.exception.code, NO_OBJECT)

        # ---- SDO aborts -----------------------------------------------------
        missing = next(i for i in (0x1FFF, 0x2FFF, 0x5FFF, 0x9FFF) if i not in od)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            upload(missing)
        self.assertEqual(e.exception.code, NO_OBJECT)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            upload(0x1018, 0x7F)
        self.assertEqual(e.exception.code, NO_SUB_INDEX)

        # ---- SDO round trip: the node answers at once, QEMU's socket too ----
        # Without `nodelay=on` on QEMU's -serial socket an answer waits for the
        # client's delayed ACK: about 45 ms per round trip instead of 2, and a
        # PLC's 0.3 s SDO timeout (python-canopen's default) is close.
        took = []
        for _ in range(21):
            start = time.monotonic()
            upload(0x1000)
            took.append(time.monotonic() - start)
        took.sort()
        self.assertLess(took[10], ROUND_TRIP, f"median SDO round trip {took[10] * 1000:.1f} ms")

        # ---- NMT start, then heartbeat (or node guarding without 0x1017) --
        node.nmt.send_command(0x01)
        error_control = 0x700 + node_id
        if 0x1017 in od:
            node.sdo.download(0x1017, 0, struct.pack("<H", 50))
            mark = frames.mark()
            beats = [frames.wait_for(lambda m: m.arbitration_id == error_control, after=mark)]
            beats.append(frames.wait_for(lambda m: m.arbitration_id == error_control and m is not beats[0], after=mark))
            for beat in beats:
                self.assertIsNotNone(beat, "no heartbeat")
                self.assertEqual(bytes(beat.data), bytes([OPERATIONAL]), "heartbeat state")
            # The guest's clock keeps wall time (a PLC times the node by its own
            # clock): it sleeps with WFI and `sleep=on` passes that time in real
            # time. While it spun on WFE the 50 ms came every 68-145 ms.
            while len(beats) < 9:
                seen = len(beats)
                beats.append(frames.wait_for(
                    lambda m: m.arbitration_id == error_control and all(m is not b for b in beats[:seen]), after=mark))
                self.assertIsNotNone(beats[-1], "no heartbeat")
            mean = (beats[-1].timestamp - beats[1].timestamp) / (len(beats) - 2)
            self.assertTrue(0.8 * 0.05 < mean < 1.25 * 0.05, f"heartbeat every {mean * 1000:.1f} ms of wall time, not 50")
        else:
            mark = frames.mark()
            q.network.send_message(error_control, b"", remote=True)
            guard = frames.wait_for(lambda m: m.arbitration_id == error_control, after=mark)
            self.assertIsNotNone(guard, "no node-guarding answer")
            self.assertEqual(guard.data[0] & 0x7F, OPERATIONAL, "guarded state")

        # ---- PDOs both ways, where the device has them ---------------------
        if device == "sendix":
            self.check_encoder(node, q, frames, node_id)
        elif 0x1800 in od:
            self.check_tpdo(node, frames, od)
        if 0x1400 in od:
            self.check_rpdo(node, q, od)
        rejected = self.check_filter(q, node, node_id, od)
        if device in CIA402:
            self.check_cia402(node, q)

        # ---- nothing went wrong on the way ---------------------------------
        emcy = frames.since(0, 0x80 + node_id)
        self.assertEqual([bytes(m.data).hex() for m in emcy], [], "unexpected EMCY")
        self.assertEqual(u(0x1001), 0, "error register")

        # ---- store (0x1010, RAM-backed on this board) survives reset node ---
        if 0x1010 in od:
            # Sub 1 "all", or sub 2 "communication" where sub 1 reads 0 ("does not save
            # on command": the b maXX 4400, whose store works in Pre-operational only, D10).
            sub = 1 if u(0x1010, 1) & 1 else 2
            node.nmt.send_command(0x80)
            node.sdo.download(0x1010, sub, b"save")
            mark = frames.mark()
            node.nmt.send_command(0x81)
            boot = frames.wait_for(lambda m: m.arbitration_id == error_control and bytes(m.data) == b"\x00", after=mark)
            self.assertIsNotNone(boot, "no boot-up after reset node")
            self.assertEqual(u(0x1017), 50, "stored 0x1017 after reset node")
            if device == "sendix":
                self.assertEqual(u(0x6003), 1000, "the preset, stored when written, after reset node")

        # ---- the end: semihosting exit with status 0 -----------------------
        self.assertEqual(q.exit(0), 0, "QEMU exit code")
        return rejected

    def check_filter(self, q, node, node_id, od):
        """Frames on identifiers the node does not consume stop at the
        board's acceptance filter (the SLCAN receive path checks the node's
        list); an RPDO moved to a new COB-ID is received there, and no
        longer on the old one. Returns how many frames the filter dropped."""
        other = node_id % 127 + 1
        # An SDO request for another node, and a heartbeat nobody here consumes.
        q.network.send_message(0x600 + other, b"\x40\x00\x10\x00\x00\x00\x00\x00")
        q.network.send_message(0x700 + other, b"\x05")
        rejected = 2
        rpdo = od.get_variable(0x1400, 1) if 0x1400 in od else None
        if rpdo is not None and rpdo.writable:
            old = int.from_bytes(node.sdo.upload(0x1400, 1), "little") & 0x7FF
            new = 0x500 + node_id
            # A COB-ID changes only while the PDO is not valid (CiA 301 §7.5.2.35),
            # and in Pre-operational: the b maXX 4400 refuses PDO changes in
            # Operational (docs/devices/bmaxx4400.md, D27). The node handles
            # frames in order, so the NMT commands need no pause.
            node.nmt.send_command(0x80)
            node.sdo.download(0x1400, 1, struct.pack("<I", 0x80000000 | new))
            node.sdo.download(0x1400, 1, struct.pack("<I", new))
            node.nmt.send_command(0x01)
            before = [node.sdo.upload(i, s) for i, s, _ in self.mapping(node, 0x1600)]
            q.network.send_message(old, bytes(len(b"".join(before))))
            rejected += 1
            after = [node.sdo.upload(i, s) for i, s, _ in self.mapping(node, 0x1600)]
            self.assertEqual(after, before, "an RPDO on the old COB-ID changed nothing")
            self.check_rpdo(node, q, od)
        return rejected

    def check_cia402(self, node, q):
        """python-canopen's BaseNode402 drives the image as tests/python/test_cia402.py
        drives vnode: each state change within BaseNode402's own timeouts (0.4 s per
        state, 0.8 s in all), a profile velocity move measured by 0x606C and 0x6064, quick
        stop while moving, homing 37, a profile position move to 0x607A absolute and
        relative measured by 0x6064. The statusword comes in
        the synchronous TPDO3 (0x6041 + 0x606C) on the PLC's SYNC every 20 ms; TPDO1 and
        TPDO2 are switched off: their event timers run on the image's clock (-icount),
        which lags the wall clock up to five times, and BaseNode402 waits at most 0.2 s
        for a TPDO it has seen twice."""
        def i32(index):
            return int.from_bytes(node.sdo.upload(index, 0), "little", signed=True)

        def wait(what, condition):
            end = time.monotonic() + WAIT
            while not condition():
                self.assertLess(time.monotonic(), end, what)
                time.sleep(0.02)

        node.nmt.send_command(0x80)
        for tpdo in (0x1800, 0x1801):
            cob_id = int.from_bytes(node.sdo.upload(tpdo, 1), "little")
            node.sdo.download(tpdo, 1, struct.pack("<I", cob_id | 0x80000000))
        node.setup_402_state_machine()
        node.nmt.send_command(0x01)
        q.network.sync.start(0.02)
        try:
            self.assertEqual(node.sdo[0x6041].raw & 0x4F, 0x40, "Switch on disabled")
            for state in ["READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED", "SWITCHED ON",
                          "READY TO SWITCH ON", "SWITCH ON DISABLED", "OPERATION ENABLED", "SWITCH ON DISABLED"]:
                start = time.monotonic()
                node.state = state
                self.assertEqual(node.state, state)
                self.assertLess(time.monotonic() - start, 0.4, state)
            # Profile velocity: 100 mm/s.
            node.op_mode = "PROFILED VELOCITY"
            self.assertEqual(node.op_mode, "PROFILED VELOCITY")
            node.state = "OPERATION ENABLED"
            start = i32(0x6064)
            node.sdo[0x60FF].raw = 100
            wait("0x606C reaches 100 mm/s", lambda: i32(0x606C) == 100)
            wait("target reached", lambda: node.sdo[0x6041].raw & 0x0400)
            wait("0x6064 advances", lambda: i32(0x6064) > start + 5)
            # Quick stop while moving (0x605A's default 2): braking, then Switch on disabled.
            node.state = "QUICK STOP ACTIVE"
            wait("Switch on disabled after the quick stop", lambda: node.sdo[0x6041].raw & 0x4F == 0x40)
            self.assertEqual(i32(0x606C), 0)
            node.state = "OPERATION ENABLED"
            # Homing 37: the position of the moment is home.
            # Not through BaseNode402.homing(): it reads the statusword of the first TPDO after
            # the start, which a SYNC can send before the start arrives, and then takes
            # "not started" (bit 10 alone) for "interrupted".
            self.assertNotEqual(i32(0x6064), 0)
            node.op_mode = "HOMING"
            node.controlword = 0x1F
            # pv's bits 12 and 10 (speed 0, target reached) look the same: the position tells.
            wait("homing attained at 0", lambda: node.sdo[0x6041].raw & 0x3400 == 0x1400 and i32(0x6064) == 0)
            node.controlword = 0x0F
            # Profile position: 50 mm, then 20 mm back relative.
            node.op_mode = "PROFILED POSITION"
            node.state = "OPERATION ENABLED"
            for target, controlword, at in [(50, 0x1F, 50), (-20, 0x5F, 30)]:
                node.sdo[0x607A].raw = target
                node.controlword = controlword
                wait("set-point acknowledge", lambda: node.sdo[0x6041].raw & 0x1000)
                node.controlword = controlword & ~0x10
                wait(f"target reached at {at} mm", lambda: node.sdo[0x6041].raw & 0x0400 and i32(0x6064) == at)
            node.state = "SWITCH ON DISABLED"
        finally:
            q.network.sync.stop()

    def mapping(self, node, index):
        """(index, sub, bits) of each object a PDO maps, read from the node."""
        count = int.from_bytes(node.sdo.upload(index, 0), "little")
        entries = [int.from_bytes(node.sdo.upload(index, s), "little") for s in range(1, count + 1)]
        return [(e >> 16, (e >> 8) & 0xFF, e & 0xFF) for e in entries]

    def check_tpdo(self, node, frames, od):
        cob_id = int.from_bytes(node.sdo.upload(0x1800, 1), "little")
        self.assertFalse(cob_id & 0x80000000, "TPDO1 is disabled by default")
        # An event timer of 50 ms: TPDO1 goes out periodically in Operational.
        node.sdo.download(0x1800, 5, struct.pack("<H", 50))
        mapped = self.mapping(node, 0x1A00)
        mark = frames.mark()
        pdo = frames.wait_for(lambda m: m.arbitration_id == cob_id & 0x7FF, after=mark)
        self.assertIsNotNone(pdo, "no TPDO1")
        expected = b"".join(node.sdo.upload(i, s)[: bits // 8] for i, s, bits in mapped)
        self.assertEqual(bytes(pdo.data), expected, f"TPDO1 maps {[(hex(i), s) for i, s, _ in mapped]}")

    def check_encoder(self, node, q, frames, node_id):
        """The Sendix (CiA 406): its simulated shaft turns, so the position
        moves by SDO, TPDO2 carries the position sampled at its SYNC, TPDO1
        follows the cyclic timer 0x6200, TPDO3 the speed, and a preset sets
        the position at once."""

        def position():
            return int.from_bytes(node.sdo.upload(0x6004, 0), "little")

        def ahead(a, b):
            """How far b is ahead of a (the shaft turns clockwise, scaling off: modulo 2^32)."""
            return (b - a) % (1 << 32)

        first = position()
        time.sleep(0.2)
        second = position()
        self.assertTrue(0 < ahead(first, second) < 1 << 24, f"the position moves: {first} -> {second}")
        # TPDO2 (TT 1): one per SYNC, between the positions read before and after.
        before = position()
        mark = frames.mark()
        q.network.send_message(0x80, b"")
        sync_pdo = frames.wait_for(lambda m: m.arbitration_id == 0x280 + node_id, after=mark)
        after = position()
        self.assertIsNotNone(sync_pdo, "no TPDO2 on SYNC")
        at_sync = int.from_bytes(sync_pdo.data, "little")
        self.assertLessEqual(ahead(before, at_sync), ahead(before, after), (before, at_sync, after))
        # TPDO1 on the cyclic timer: its frames move forward.
        node.sdo.download(0x6200, 0, struct.pack("<H", 50))
        self.assertEqual(node.sdo.upload(0x1800, 5), struct.pack("<H", 50), "0x6200 is TPDO1's event timer")
        mark = frames.mark()
        one = frames.wait_for(lambda m: m.arbitration_id == 0x180 + node_id, after=mark)
        self.assertIsNotNone(one, "no TPDO1")
        two = frames.wait_for(lambda m: m.arbitration_id == 0x180 + node_id and m is not one, after=mark)
        self.assertIsNotNone(two, "no second TPDO1")
        self.assertGreater(ahead(int.from_bytes(one.data, "little"), int.from_bytes(two.data, "little")), 0)
        # TPDO3: the speed of the image's shaft, 30 rpm.
        node.sdo.download(0x1802, 5, struct.pack("<H", 100))
        mark = frames.mark()
        speed = frames.wait_for(lambda m: m.arbitration_id == 0x380 + node_id, after=mark)
        self.assertIsNotNone(speed, "no TPDO3")
        self.assertIn(int.from_bytes(speed.data, "little", signed=True), (29, 30, 31), "30 rpm")
        # The preset: the position at once (plus what the shaft turned since).
        node.sdo.download(0x6003, 0, struct.pack("<I", 1000))
        self.assertLess(ahead(1000, position()), 1 << 16, "the preset applied")

    def check_rpdo(self, node, q, od):
        cob_id = int.from_bytes(node.sdo.upload(0x1400, 1), "little")
        self.assertFalse(cob_id & 0x80000000, "RPDO1 is disabled by default")
        payload, expected = b"", []
        for index, sub, bits in self.mapping(node, 0x1600):
            var = od.get_variable(index, sub)
            signed = var.data_type in SIGNED
            current = int.from_bytes(node.sdo.upload(index, sub), "little", signed=signed)
            top = var.max if var.max is not None else (1 << (bits - signed)) - 1
            # A value the object has not got yet, inside its limits.
            value = current + 1 if current < top else current - 1
            raw = (value & ((1 << bits) - 1)).to_bytes(bits // 8, "little")
            payload += raw
            expected.append((index, sub, raw))
        q.network.send_message(cob_id & 0x7FF, payload)
        for index, sub, raw in expected:
            # The node applies the RPDO before it answers the next SDO request.
            self.assertEqual(node.sdo.upload(index, sub), raw, f"RPDO1 -> 0x{index:04X} sub {sub}")


def add_device_tests():
    for device in DEVICES:
        name = "test_" + device.replace("-", "_")
        setattr(QemuSmokeTest, name, lambda self, d=device: self.run_device(d))


add_device_tests()

if __name__ == "__main__":
    unittest.main()
