"""A device made by `cargo xtask new-device` boots in QEMU and python-canopen drives it.

`cargo xtask test` makes each device from a corpus EDS, builds its QEMU image
and runs this with NEW_DEVICE_ELF (the image), NEW_DEVICE_NODE_ID,
NEW_DEVICE_EDS and NEW_DEVICE_PROFILE (none, cia402, cia406) set; without them the
tests are skipped. QEMU is started as the smoke tests start it
(test_qemu_smoke.QemuImage).
"""

import os
import struct
import sys
import tempfile
import time
import unittest

import canopen

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import test_qemu_smoke as smoke  # noqa: E402

ELF = os.environ.get("NEW_DEVICE_ELF")
PROFILE = os.environ.get("NEW_DEVICE_PROFILE", "none")


class Booted(unittest.TestCase):
    """Boots the image in QEMU; `self.node` reaches it by SDO."""

    def boot(self):
        node_id = int(os.environ["NEW_DEVICE_NODE_ID"])
        release = tempfile.mkdtemp()
        self.addCleanup(lambda: (os.unlink(os.path.join(release, "new-device-qemu")), os.rmdir(release)))
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
        self.node = q.network.add_node(node_id, canopen.ObjectDictionary())
        self.node.sdo.RESPONSE_TIMEOUT = 3.0
        return node_id


@unittest.skipUnless(ELF and PROFILE == "none", "run through `cargo xtask test` (NEW_DEVICE_ELF)")
class NewDeviceTest(Booted):
    def test_boots_and_answers_identity(self):
        node_id = self.boot()
        node = self.node
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


def u16(raw):
    return struct.unpack("<H", raw)[0]


def i32(raw):
    return struct.unpack("<i", raw)[0]


@unittest.skipUnless(ELF and PROFILE == "cia402", "run through `cargo xtask test` (NEW_DEVICE_ELF, --profile cia402)")
class NewDriveTest(Booted):
    """The generated CiA 402 device runs the profile on the axis model:
    the statusword 0x6041 follows the controlword 0x6040 through the state
    machine (CiA 402-2 §6, "State coding") to Operation enabled, and in
    profile velocity the axis moves."""

    def statusword(self):
        return u16(self.node.sdo.upload(0x6041, 0))

    def control(self, word, mask, state, name):
        self.node.sdo.download(0x6040, 0, struct.pack("<H", word))
        end = time.monotonic() + 2.0
        while self.statusword() & mask != state:
            self.assertLess(time.monotonic(), end, f"{name}: statusword 0x{self.statusword():04X}")
            time.sleep(0.01)

    def test_the_state_machine_reaches_operation_enabled_and_the_axis_moves(self):
        self.boot()
        # After reset application: Switch on disabled (xxxx xxxx x1xx 0000).
        self.assertEqual(self.statusword() & 0x4F, 0x40, f"statusword 0x{self.statusword():04X}")
        # The ros2-canopen EDS declares pp, pv, hm and csp (0x6502 = 0xA5); pv moves the axis.
        self.node.sdo.download(0x6060, 0, struct.pack("<b", 3))
        self.assertEqual(self.node.sdo.upload(0x6061, 0), b"\x03", "modes of operation display")
        self.node.nmt.send_command(0x01)
        self.control(0x06, 0x6F, 0x21, "Shutdown → Ready to switch on")
        self.control(0x07, 0x6F, 0x23, "Switch on → Switched on")
        self.control(0x0F, 0x6F, 0x27, "Enable operation → Operation enabled")
        start = i32(self.node.sdo.upload(0x6064, 0))
        self.node.sdo.download(0x60FF, 0, struct.pack("<i", 20000))
        end = time.monotonic() + 3.0
        while i32(self.node.sdo.upload(0x606C, 0)) <= 0:
            self.assertLess(time.monotonic(), end, "velocity actual 0x606C stays 0")
            time.sleep(0.02)
        time.sleep(0.2)
        self.assertGreater(i32(self.node.sdo.upload(0x6064, 0)), start, "position actual 0x6064 moved")
        # Disable voltage: Switch on disabled again, the axis coasts.
        self.control(0x00, 0x4F, 0x40, "Disable voltage → Switch on disabled")


@unittest.skipUnless(ELF and PROFILE == "cia406", "run through `cargo xtask test` (NEW_DEVICE_ELF, --profile cia406)")
class NewEncoderTest(Booted):
    """The generated CiA 406 device runs the profile on its simulated shaft
    (30 rpm of the EDS's 0x6501 steps per turn): the position 0x6004 moves,
    and the cyclic timer 0x6200 is TPDO1's event timer 0x1800:05."""

    def test_the_position_moves_and_the_cyclic_timer_is_tpdo1s_event_timer(self):
        self.boot()
        steps = struct.unpack("<I", self.node.sdo.upload(0x6501, 0))[0]
        first = struct.unpack("<I", self.node.sdo.upload(0x6004, 0))[0]
        time.sleep(0.3)
        later = struct.unpack("<I", self.node.sdo.upload(0x6004, 0))[0]
        # Half a turn per second, clockwise: about 0.15 turn in 0.3 s (wall time in QEMU: at least some).
        self.assertGreater((later - first) % 2**32, 0, f"0x6004 {first} → {later}")
        self.assertLess((later - first) % 2**32, steps * 2, f"0x6004 {first} → {later}")
        self.node.sdo.download(0x6200, 0, struct.pack("<H", 50))
        self.assertEqual(self.node.sdo.upload(0x1800, 5), struct.pack("<H", 50))


if __name__ == "__main__":
    unittest.main()
