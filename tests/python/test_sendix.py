"""The Sendix encoder (CiA 406) through python-canopen, an independent master, in `vnode`.

The image's simulated shaft turns at 30 rpm clockwise (0x4000 steps per turn, ±2 steps of
noise), so the position moves for a master: by SDO, by PDO on SYNC (TPDO2) and on the cyclic
timer 0x6200 (TPDO1), the speed by SDO and TPDO3; a preset and a save survive a restart of
the process on the same storage file.
"""

import os
import struct
import tempfile
import threading
import time
import unittest

from test_interop import ROOT, Vnode

EDS = os.path.join(ROOT, "firmware", "eds", "sendix.eds")
NODE = 0x3F
STEPS_PER_S = 0x2000  # 30 rpm
RANGE = 1 << 32  # 0x6004 with scaling off


def u32(data):
    return struct.unpack("<I", data)[0]


def i32(data):
    return struct.unpack("<i", data)[0]


class Frames:
    """Every frame on one COB-ID, with its arrival time."""

    def __init__(self, network, cob_id):
        self.items = []
        self.cond = threading.Condition()
        self.network, self.cob_id = network, cob_id
        network.subscribe(cob_id, self.on_frame)

    def on_frame(self, can_id, data, timestamp):
        with self.cond:
            self.items.append((time.monotonic(), bytes(data)))
            self.cond.notify_all()

    def wait(self, n, timeout=3.0):
        end = time.monotonic() + timeout
        with self.cond:
            while len(self.items) < n and time.monotonic() < end:
                self.cond.wait(end - time.monotonic())
            return list(self.items)

    def close(self):
        self.network.unsubscribe(self.cob_id, self.on_frame)


class SendixTest(unittest.TestCase):
    def start(self, storage=None):
        extra = ("--storage", storage) if storage else ()
        v = Vnode(device="sendix", node_id=NODE, eds=EDS, extra=extra)
        self.addCleanup(v.close)
        # A loaded machine (CI) can take longer than python-canopen's 0.3 s.
        v.node.sdo.RESPONSE_TIMEOUT = 2.0
        v.node.sdo.upload(0x1000, 0)
        return v

    def test_position_and_speed_by_sdo(self):
        node = self.start().node
        before = time.monotonic()
        first = u32(node.sdo.upload(0x6004, 0))
        time.sleep(0.3)
        second = u32(node.sdo.upload(0x6004, 0))
        took = time.monotonic() - before
        moved = (second - first) % RANGE
        # At least 0.3 s at 8192 steps/s, at most the time the two exchanges took.
        self.assertGreater(moved, 1500, (first, second))
        self.assertLess(moved, 8192 * took + 200, (first, second, took))
        self.assertEqual(node.sdo.upload(0x6501, 0), struct.pack("<I", 0x4000))
        self.assertIn(i32(node.sdo.upload(0x6030, 1)), (29, 30, 31), "30 rpm")
        # The raw position CRC (0x2162) and the raw value travel together.
        self.assertEqual(len(node.sdo.upload(0x2162, 0)), 2)

    def test_position_on_sync_tpdo2(self):
        v = self.start()
        node = v.node
        node.tpdo.read()
        node.nmt.state = "OPERATIONAL"
        frames = Frames(v.network, 0x280 + NODE)
        self.addCleanup(frames.close)
        for _ in range(3):
            v.network.sync.transmit()
            time.sleep(0.1)
        got = frames.wait(3)
        self.assertEqual(len(got), 3, "one TPDO2 per SYNC (TT 1)")
        positions = [u32(data) for _, data in got]
        for (ta, a), (tb, b) in zip(got, got[1:]):
            # The shaft turns 0x2000 steps/s: the step between two SYNC TPDOs follows the time between them
            # (about 819 steps for the 0.1 s sleep; a loaded machine sleeps longer). The arrival times carry
            # the SLCAN and scheduling latency of both frames, hence the margin.
            steps, expected = (u32(b) - u32(a)) % RANGE, STEPS_PER_S * (tb - ta)
            self.assertTrue(0.5 * expected - 200 < steps < 1.5 * expected + 200, (positions, steps, tb - ta))
        # python-canopen decodes it as 0x6004 from the mapping it read.
        self.assertEqual(node.tpdo[2]["Position value"].raw, positions[-1])

    def test_position_on_the_cyclic_timer_tpdo1(self):
        v = self.start()
        node = v.node
        node.sdo.download(0x6200, 0, struct.pack("<H", 50))
        frames = Frames(v.network, 0x180 + NODE)
        self.addCleanup(frames.close)
        node.nmt.state = "OPERATIONAL"
        time.sleep(1.0)
        node.nmt.state = "PRE-OPERATIONAL"
        got = frames.items
        # 50 ms cycle over about one second.
        self.assertTrue(15 <= len(got) <= 23, len(got))
        gaps = [b[0] - a[0] for a, b in zip(got, got[1:])]
        self.assertLess(abs(sum(gaps) / len(gaps) - 0.05), 0.01, gaps)
        positions = [u32(data) for _, data in got]
        self.assertTrue(all(0 < (b - a) % RANGE < 2000 for a, b in zip(positions, positions[1:])), positions)

    def test_speed_on_tpdo3(self):
        v = self.start()
        node = v.node
        node.sdo.download(0x1802, 5, struct.pack("<H", 200))
        frames = Frames(v.network, 0x380 + NODE)
        self.addCleanup(frames.close)
        node.nmt.state = "OPERATIONAL"
        got = frames.wait(3)
        self.assertGreaterEqual(len(got), 3)
        self.assertIn(i32(got[-1][1]), (29, 30, 31), "30 rpm on TPDO3")

    def test_preset_and_save_survive_a_restart(self):
        path = os.path.join(tempfile.mkdtemp(), "sendix.bin")
        node = self.start(path).node
        before = time.monotonic()
        node.sdo.download(0x6003, 0, struct.pack("<I", 1000))
        after = u32(node.sdo.upload(0x6004, 0))
        took = time.monotonic() - before
        # 8192 steps/s: no further than the two exchanges' time has turned it.
        self.assertLess((after - 1000) % RANGE, 8192 * took + 200, ("the position is the preset at once", took))
        # Scaling on and saved with 0x1010 (the offset, within the new range, with it).
        node.sdo.download(0x6000, 0, struct.pack("<H", 0x0004))
        node.sdo.download(0x6002, 0, struct.pack("<I", 36000))
        node.sdo.download(0x6001, 0, struct.pack("<I", 3600))
        offset = u32(node.sdo.upload(0x6509, 0))
        self.assertLess(offset, 36000)
        node.sdo.download(0x1010, 3, b"save")
        self.doCleanups()
        # The same storage in a new process: the preset, its offset and the scaling are back.
        node = self.start(path).node
        self.assertEqual(u32(node.sdo.upload(0x6003, 0)), 1000)
        self.assertEqual(u32(node.sdo.upload(0x6509, 0)), offset)
        self.assertEqual(node.sdo.upload(0x6000, 0), struct.pack("<H", 0x0004))
        position = u32(node.sdo.upload(0x6004, 0))
        self.assertLess(position, 36000)


if __name__ == "__main__":
    unittest.main()
