"""`vnode --eds FILE`: any EDS runs on the PC, read by od-gen when vnode starts.

python-canopen drives a corpus EDS (CANopenNode's demo device) over SLCAN with
raw SDO transfers: its own EDS parser rejects that file (empty VendorNumber),
which is no reason not to talk to the node. Runs with the venv `cargo xtask
test` creates:
    .venv/bin/python -m unittest tests/python/test_vnode_eds.py -v
"""

import os
import re
import struct
import subprocess
import unittest

import canopen

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VNODE = os.environ.get("VNODE", os.path.join(ROOT, "target", "debug", "vnode"))
CORPUS = os.path.join(ROOT, "tests", "eds-corpus")
DEMO = os.path.join(CORPUS, "canopendemo__demoDevice.eds")
NODE_ID = 9


class VnodeEdsTest(unittest.TestCase):
    def setUp(self):
        self.proc = subprocess.Popen(
            [VNODE, "--eds", DEMO, "--node-id", str(NODE_ID), "--listen", "127.0.0.1:0"],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        self.addCleanup(self.stop)
        line = self.proc.stdout.readline()
        port = int(re.search(r":(\d+)\s*$", line).group(1))
        self.network = canopen.Network()
        self.network.NOTIFIER_CYCLE = 0.05  # a fast disconnect (test_interop.Vnode)
        self.network.connect(interface="slcan", channel=f"socket://127.0.0.1:{port}", bitrate=500000, sleep_after_open=0)
        self.addCleanup(self.network.disconnect)
        self.node = self.network.add_node(NODE_ID, canopen.ObjectDictionary())
        self.node.sdo.RESPONSE_TIMEOUT = 2.0

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=5)
        self.proc.stdout.close()

    def u32(self, index, sub):
        return struct.unpack("<I", self.node.sdo.upload(index, sub))[0]

    def test_device_type_and_identity_come_from_the_eds(self):
        self.assertEqual(self.u32(0x1000, 0), 0x000F0191)
        self.assertEqual(self.node.sdo.upload(0x1018, 0), b"\x04")
        self.assertEqual(self.u32(0x1018, 1), 0)

    def test_nodeid_defaults_are_resolved(self):
        self.assertEqual(self.u32(0x1014, 0), 0x80 + NODE_ID)

    def test_writable_objects_keep_what_is_written(self):
        self.node.sdo.download(0x1017, 0, struct.pack("<H", 250))
        self.assertEqual(self.node.sdo.upload(0x1017, 0), struct.pack("<H", 250))
        self.node.sdo.download(0x2110, 1, struct.pack("<i", -123456))
        self.assertEqual(self.node.sdo.upload(0x2110, 1), struct.pack("<i", -123456))

    def test_read_only_and_missing_objects_abort(self):
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo.download(0x1000, 0, b"\0\0\0\0")
        self.assertEqual(e.exception.code, 0x06010002)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo.upload(0x5FFF, 0)
        self.assertEqual(e.exception.code, 0x06020000)


class VnodeEdsErrorTest(unittest.TestCase):
    def test_an_invalid_eds_is_reported_by_line_and_exits_1(self):
        eds = os.path.join(CORPUS, "heig-vd__od.eds")
        run = subprocess.run([VNODE, "--eds", eds, "--node-id", "1"], capture_output=True, text=True, timeout=30)
        self.assertEqual(run.returncode, 1)
        self.assertIn(f"{eds}:1276: error: value `0.0f` is not a REAL32 number", run.stderr)
        self.assertEqual(run.stdout, "")


if __name__ == "__main__":
    unittest.main()
