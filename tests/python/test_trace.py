"""`vnode --trace FILE` read back by python-can's `can.LogReader`, with two python-can
`slcan` adapters on vnode's bus: a master that talks to the node and an observer that
only listens.

Runs with the venv `cargo xtask test` creates:
    .venv/bin/python -m unittest discover -s tests/python -v
"""

import collections
import os
import re
import subprocess
import tempfile
import time
import unittest

import can

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VNODE = os.environ.get("VNODE", os.path.join(ROOT, "target", "debug", "vnode"))
NODE_ID = 5


def key(msg):
    """What identifies a frame on the bus, whoever logged it."""
    data = b"" if msg.is_remote_frame else bytes(msg.data)
    return (msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame, msg.dlc, data)


def adapter(port):
    return can.Bus(interface="slcan", channel=f"socket://127.0.0.1:{port}", bitrate=1000000, sleep_after_open=0)


class TraceTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.addCleanup(self.dir.cleanup)
        self.trace = os.path.join(self.dir.name, "session.log")
        self.proc = subprocess.Popen(
            [VNODE, "--device", "ec5000", "--node-id", str(NODE_ID), "--listen", "127.0.0.1:0", "--trace", self.trace],
            stdout=subprocess.PIPE,
            text=True,
        )
        self.addCleanup(self.stop)
        line = self.proc.stdout.readline()
        self.port = int(re.search(r":(\d+)\s*$", line).group(1))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=5)
        self.proc.stdout.close()

    def test_log_reader_finds_every_frame_of_a_session(self):
        started = time.time()
        observer = adapter(self.port)
        self.addCleanup(observer.shutdown)
        master = adapter(self.port)
        self.addCleanup(master.shutdown)
        # python-can sends O when it opens; give the server a moment to see both channels open.
        time.sleep(0.2)
        sent = [
            can.Message(arbitration_id=0x000, data=[0x01, NODE_ID], is_extended_id=False),  # NMT start
            *[can.Message(arbitration_id=0x080, data=[], is_extended_id=False) for _ in range(5)],  # SYNC
            can.Message(arbitration_id=0x600 + NODE_ID, data=[0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0], is_extended_id=False),
            can.Message(arbitration_id=0x700 + NODE_ID, is_remote_frame=True, dlc=1, is_extended_id=False),  # node guarding
            can.Message(arbitration_id=0x1ABCDEF0, data=[0xBE, 0xEF], is_extended_id=True),
        ]
        for msg in sent:
            master.send(msg)
            time.sleep(0.01)
        seen = []
        while (msg := observer.recv(timeout=0.5)) is not None:
            seen.append(msg)
        time.sleep(0.3)  # the trace writer flushes whenever its queue runs empty
        self.stop()

        logged = list(can.LogReader(self.trace))
        self.assertTrue(logged, "the trace is empty")
        self.assertTrue(all(m.channel == "can0" for m in logged))
        self.assertTrue(all(started - 1 <= m.timestamp <= time.time() + 1 for m in logged), "timestamps are Unix time")
        stamps = [m.timestamp for m in logged]
        self.assertEqual(stamps, sorted(stamps))
        # The boot-up is the first frame of the trace.
        self.assertEqual(key(logged[0]), (0x700 + NODE_ID, False, False, 1, b"\x00"))

        trace = collections.Counter(key(m) for m in logged)
        # The observer is an adapter on the same bus: it sees every frame the master sent...
        self.assertLessEqual(collections.Counter(key(m) for m in sent), collections.Counter(key(m) for m in seen))
        # ...and the node's answers: 5 TPDO3 (SYNC, type 1), the SDO answer, the guarding answer.
        # On a loaded machine the observer may connect before the boot-up
        # leaves: then it has seen it too (the boot-up is the only 0x700 + id
        # frame with data 00; a guarding answer carries the state, 05 or 85).
        boot_ups = sum(1 for m in seen if key(m) == (0x700 + NODE_ID, False, False, 1, b"\x00"))
        answers = collections.Counter(key(m)[0] for m in seen)
        self.assertEqual((answers[0x380 + NODE_ID], answers[0x580 + NODE_ID]), (5, 1))
        self.assertEqual(answers[0x700 + NODE_ID] - boot_ups, 2, "the guarding request and its answer")
        # Every frame of the session is in the trace, each as often as it was on the bus.
        self.assertLessEqual(collections.Counter(key(m) for m in seen), trace)
        self.assertEqual(sum(trace.values()), len(seen) + 1 - boot_ups)


if __name__ == "__main__":
    unittest.main()
