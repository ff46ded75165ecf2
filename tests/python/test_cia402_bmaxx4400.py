"""CiA 402 through python-canopen's BaseNode402: the Baumüller b maXX 4400 in `vnode`.

State changes through RPDO1 (0x6040) within BaseNode402's timeouts; a pv move in the
manufacturer's speed control mode −3 measured by 0x606C; a pp move (after the homing the
CANopen positioning mode requires) measured by 0x6064 and the drive parameter P0462
(0x6064 + 2^31); interpolated position following the records each SYNC takes. The dictionary
has no 0x6502, so the modes are written to 0x6060 by SDO rather than through `op_mode`
(docs/devices/bmaxx4400.md D51).
"""

import os
import struct
import time
import unittest

from drive402 import Drive402Test
from test_interop import ROOT

EDS = os.path.join(ROOT, "firmware", "eds", "bmaxx4400.eds")
NODE_ID = 4


class Bmaxx4400(Drive402Test):
    DEVICE, NODE_ID, EDS = "bmaxx4400", NODE_ID, EDS
    EVENT_TIMED_TPDOS = (0x1800,)

    def i32(self, index):
        return struct.unpack("<i", self.drive.sdo.upload(index, 0))[0]

    def mode(self, value):
        self.drive.sdo.download(0x6060, 0, struct.pack("<b", value))

    def test_state_changes_through_the_state_machine(self):
        self.assertEqual(self.drive.sdo[0x6041].raw & 0x4F, 0x40)
        for state in ["READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED", "SWITCHED ON",
                      "READY TO SWITCH ON", "SWITCH ON DISABLED", "OPERATION ENABLED"]:
            start = time.monotonic()
            self.drive.state = state
            self.assertEqual(self.drive.state, state)
            self.assertLess(time.monotonic() - start, self.STATE_CHANGE, state)

    def test_speed_control_minus_3_reads_back_3_and_moves(self):
        self.mode(-3)
        self.assertEqual(self.drive.sdo[0x6061].raw, 3)
        self.drive.state = "OPERATION ENABLED"
        self.drive.sdo[0x60FF].raw = 60  # min⁻¹: one revolution per second
        self.wait_for("60 min⁻¹", lambda: self.i32(0x606C) == 60)
        moved = self.i32(0x6064)
        time.sleep(0.3)
        self.assertGreater(self.i32(0x6064) - moved, 10000)
        # 0x605A's factory value 0 would coast to SWITCH ON DISABLED at once; 6 brakes on
        # the quick stop ramp and stays in QUICK STOP ACTIVE.
        self.drive.sdo[0x605A].raw = 6
        self.drive.state = "QUICK STOP ACTIVE"
        self.wait_for("standstill in QUICK STOP ACTIVE", lambda: self.i32(0x606C) == 0, 1.0)
        self.assertEqual(self.drive.state, "QUICK STOP ACTIVE")
        self.drive.state = "SWITCH ON DISABLED"

    def test_velocity_mode_vl_move(self):
        # vl (2): 0x6042 and 0x6044 in min⁻¹ (D57, D60), the ramp 0x6048 3000 min⁻¹ per second.
        self.mode(2)
        self.assertEqual(self.drive.sdo[0x6061].raw, 2)
        self.drive.sdo[0x6048][1].raw = 3000
        self.drive.sdo[0x6048][2].raw = 1
        self.drive.state = "OPERATION ENABLED"
        self.drive.sdo[0x6042].raw = 60  # one revolution per second
        self.wait_for("60 min⁻¹", lambda: self.drive.sdo[0x6044].raw == 60 and self.i32(0x606C) == 60)
        moved = self.i32(0x6064)
        time.sleep(0.3)
        self.assertGreater(self.i32(0x6064) - moved, 10000)
        self.drive.state = "SWITCH ON DISABLED"

    def test_profile_position_move(self):
        # The CANopen positioning mode (P0601 = 9) positions only after a homing since
        # power-on (§4.4.8, D61): method 35, the current position, in hm first.
        self.drive.sdo[0x6098].raw = 35
        self.mode(6)
        self.drive.state = "OPERATION ENABLED"
        self.drive.controlword = 0x1F
        self.wait_for("homing attained", lambda: self.drive.sdo[0x6041].raw & 0x1400 == 0x1400)
        self.drive.controlword = 0x0F
        self.mode(1)
        self.drive.sdo[0x6067].raw = 16
        self.drive.sdo[0x6081].raw = 655360
        self.drive.sdo[0x6083].raw = 6553600
        self.drive.sdo[0x6084].raw = 6553600
        self.drive.state = "OPERATION ENABLED"
        self.drive.sdo[0x607A].raw = 131072
        self.drive.controlword = 0x1F
        self.wait_for("set-point acknowledge", lambda: self.drive.sdo[0x6041].raw & 0x1000)
        self.drive.controlword = 0x0F
        self.wait_for("target reached at two revolutions",
                      lambda: self.drive.sdo[0x6041].raw & 0x0400 and abs(self.i32(0x6064) - 131072) <= 1)
        p0462 = struct.unpack("<I", self.drive.sdo.upload(0x41CE, 0))[0]
        self.assertEqual(p0462, (self.i32(0x6064) + 2**31) % 2**32)

    def test_interpolated_position_follows_the_records_taken_on_sync(self):
        # App. C 60C0h-60C4h (D58): 0x60C1 sub 1 in increments, taken on every SYNC; the
        # default period 0x60C2 is 2 ms. Records a hundredth of a revolution apart.
        self.mode(7)
        self.drive.sdo[0x6067].raw = 16  # position window for target reached (factory value 0)
        self.drive.state = "OPERATION ENABLED"
        self.drive.controlword = 0x1F
        self.wait_for("ip mode active", lambda: self.drive.sdo[0x6041].raw & 0x1000)
        for k in range(1, 101):
            self.drive.sdo[0x60C1][1].raw = 655 * k
            self.v.network.sync.transmit()
            if k == 50:
                self.assertTrue(0 < self.i32(0x6064) <= 655 * 50, "moving with the records")
        self.v.network.sync.transmit()
        self.wait_for("on the last record, target reached",
                      lambda: abs(self.i32(0x6064) - 65500) <= 16 and self.drive.sdo[0x6041].raw & 0x1400 == 0x1400)
        self.drive.controlword = 0x0F
        self.wait_for("ip mode inactive", lambda: not self.drive.sdo[0x6041].raw & 0x1000)

    def test_manufacturer_modes_are_shown(self):
        for value, shown in [(-106, -106), (-6, -6), (7, 7), (-4, -4), (2, 2)]:
            self.mode(value)
            self.assertEqual(struct.unpack("<b", self.drive.sdo.upload(0x6061, 0))[0], shown)


if __name__ == "__main__":
    unittest.main()
