"""A device made by `cargo xtask new-device` boots in QEMU and python-canopen reads it.

`cargo xtask test` makes the device from a corpus EDS, builds its QEMU image
and runs this with NEW_DEVICE_ELF (the image), NEW_DEVICE_NODE_ID and
NEW_DEVICE_EDS set; without them the test is skipped. QEMU is started as the
smoke tests start it (test_qemu_smoke.QemuImage).
"""

import os
import struct
import sys
import tempfile
import unittest

import canopen

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import test_qemu_smoke as smoke  # noqa: E402

ELF = os.environ.get("NEW_DEVICE_ELF")


@unittest.skipUnless(ELF, "run through `cargo xtask test` (NEW_DEVICE_ELF)")
class NewDeviceTest(unittest.TestCase):
    def test_boots_and_answers_identity(self):
        node_id = int(os.environ["NEW_DEVICE_NODE_ID"])
        with tempfile.TemporaryDirectory() as release:
            # QemuImage boots RELEASE/<device>-qemu.
            os.symlink(ELF, os.path.join(release, "new-device-qemu"))
            smoke.RELEASE = release
            q = smoke.QemuImage("new-device")
            self.addCleanup(q.close)
            first = q.bus.recv(smoke.WAIT)
            self.assertIsNotNone(first, f"no boot-up frame; QEMU stderr: {''.join(q.stderr)}")
            self.assertEqual((first.arbitration_id, bytes(first.data)), (0x700 + node_id, b"\x00"), "boot-up")
            q.network = canopen.Network(q.bus)
            q.network.connect()
            node = q.network.add_node(node_id, canopen.ObjectDictionary())
            node.sdo.RESPONSE_TIMEOUT = 3.0
            # The EDS's defaults (tests/eds-corpus/canopennode__DS301_profile.eds).
            self.assertEqual(struct.unpack("<I", node.sdo.upload(0x1000, 0))[0], 0)
            self.assertEqual(node.sdo.upload(0x1018, 0), b"\x04")
            self.assertEqual(len(node.sdo.upload(0x1018, 1)), 4)
            self.assertEqual(struct.unpack("<I", node.sdo.upload(0x1014, 0))[0], 0x80 + node_id)
            # The template's validation rule: a heartbeat under 10 ms is refused.
            with self.assertRaises(canopen.SdoAbortedError) as e:
                node.sdo.download(0x1017, 0, struct.pack("<H", 5))
            self.assertEqual(e.exception.code, 0x06090030)
            node.sdo.download(0x1017, 0, struct.pack("<H", 100))
            self.assertEqual(node.sdo.upload(0x1017, 0), struct.pack("<H", 100))


if __name__ == "__main__":
    unittest.main()
