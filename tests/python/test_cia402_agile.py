"""CiA 402 velocity mode through python-canopen's BaseNode402: the Bonfiglioli Agile in `vnode`.

State changes by RPDO1 (0x6040, 0x6042) within BaseNode402's timeouts, and a vl move measured
by 0x6044 as the ramps 0x6048/0x6049 give it. 0x6060 is write-only and fixed to 2, and the
dictionary has no 0x6502, so the mode is not set through `op_mode` (docs/devices/agile.md D43).
"""

import os
import struct
import time
import unittest

from drive402 import Drive402Test
from test_interop import ROOT

EDS = os.path.join(ROOT, "firmware", "eds", "agile.eds")
NODE_ID = 1


class AgileVl(Drive402Test):
    DEVICE, NODE_ID, EDS = "agile", NODE_ID, EDS
    EVENT_TIMED_TPDOS = (0x1800,)

    def rpm(self, index):
        return struct.unpack("<h", self.drive.sdo.upload(index, 0))[0]

    def test_state_changes_through_the_state_machine(self):
        self.assertEqual(self.drive.sdo[0x6041].raw & 0x4F, 0x40)
        self.assertEqual(self.drive.sdo[0x6061].raw, 2, "velocity mode")
        for state in ["READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED", "SWITCHED ON",
                      "READY TO SWITCH ON", "SWITCH ON DISABLED", "OPERATION ENABLED"]:
            start = time.monotonic()
            self.drive.state = state
            self.assertEqual(self.drive.state, state)
            self.assertLess(time.monotonic() - start, self.STATE_CHANGE, state)

    def test_vl_move_on_the_ramps(self):
        # 3000 min⁻¹ per second up, down and for quick stop.
        self.drive.sdo[0x6048][1].raw = 3000
        self.drive.sdo[0x6049][1].raw = 3000
        self.drive.sdo[0x604A][1].raw = 3000
        self.drive.state = "OPERATION ENABLED"
        self.drive.sdo[0x6042].raw = 600
        start = time.monotonic()
        self.wait_for("600 min⁻¹", lambda: self.rpm(0x6044) == 600)
        self.assertGreater(time.monotonic() - start, 0.1, "a ramp of about 0.2 s, not a step")
        self.assertTrue(self.drive.sdo[0x6041].raw & 0x0400, "target reached")
        self.drive.sdo[0x6042].raw = -300
        self.wait_for("-300 min⁻¹", lambda: self.rpm(0x6044) == -300)
        self.drive.state = "QUICK STOP ACTIVE"
        self.wait_for("quick stop ends in SWITCH ON DISABLED",
                      lambda: self.drive.sdo[0x6041].raw & 0x4F == 0x40, 2.0)
        self.assertEqual(self.rpm(0x6044), 0)

    def test_writes_of_other_modes_are_refused(self):
        from canopen.sdo.exceptions import SdoAbortedError
        self.drive.sdo[0x6060].raw = 2
        with self.assertRaises(SdoAbortedError) as e:
            self.drive.sdo[0x6060].raw = 3
        self.assertEqual(e.exception.code, 0x06090031)
        self.assertEqual(self.drive.sdo[0x6061].raw, 2)


if __name__ == "__main__":
    unittest.main()
