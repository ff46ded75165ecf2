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
    # TPDO1 (0x6041) and TPDO2 (0x6041, 0x6061) are sent on change only: BaseNode402 takes a
    # TPDO seen twice as periodic and waits 0.2 s for it (state, op_mode), so both get 100 ms.
    EVENT_TIMED_TPDOS = (0x1800, 0x1801)

    def mode(self, value):
        self.drive.sdo.download(0x6060, 0, struct.pack("<b", value))

    def test_state_changes_through_the_state_machine(self):
        self.walk_the_state_machine()

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


    # ---- as a PLC programmer uses python-canopen beyond BaseNode402's state machine ----

    def test_modes_by_rpdo2_shown_by_tpdo2_and_op_mode_without_0x6502(self):
        # python-canopen's op_mode setter asks 0x6502 first (is_op_mode_supported); the manual
        # lists no 0x6502 (D37), so it raises KeyError before it writes anything. The PLC writes
        # the mode by RPDO2 (0x6040 + 0x6060) with the controlword it is sending, since RPDO2
        # carries both (python-canopen's own op_mode would send RPDO2's controlword copy, 0:
        # disable voltage); BaseNode402's op_mode getter reads it from TPDO2 (0x6041 + 0x6061).
        with self.assertRaises(KeyError):
            self.drive.op_mode = "PROFILED VELOCITY"
        self.drive.state = "OPERATION ENABLED"
        rpdo = self.drive.rpdo[2]
        for value, name in [(3, "PROFILED VELOCITY"), (1, "PROFILED POSITION"), (6, "HOMING"), (2, "VELOCITY"),
                            (7, "INTERPOLATED POSITION")]:
            rpdo["Controlword"].raw = 0x0F
            rpdo["Modes of operation"].raw = value
            rpdo.transmit()
            self.wait_for(name, lambda: self.drive.op_mode == name, 1.0)
            self.assertEqual(self.drive.state, "OPERATION ENABLED")

    def test_pv_by_rpdo4_measured_by_a_synchronous_tpdo4_and_quick_stop_6(self):
        # TPDO4 (0x6041, 0x606C) is timer-only (type 254, no timer: D26); the PLC makes it
        # synchronous through python-canopen's PDO configuration and runs SYNC every 10 ms.
        self.drive.nmt.state = "PRE-OPERATIONAL"
        self.drive.tpdo[4].trans_type = 1
        self.drive.tpdo[4].save()
        self.drive.nmt.state = "OPERATIONAL"
        self.v.network.sync.start(0.01)
        self.addCleanup(self.v.network.sync.stop)
        self.mode(3)
        self.drive.sdo[0x605A].raw = 6  # quick stop ramp, stay in QUICK STOP ACTIVE
        # 100 revolutions per s² (6000 min⁻¹ per s) up and for the quick stop: 0.1 s each way.
        self.drive.sdo[0x6083].raw = 6553600
        self.drive.sdo[0x6085].raw = 6553600
        self.drive.state = "OPERATION ENABLED"
        rpdo, tpdo = self.drive.rpdo[4], self.drive.tpdo[4]
        names = ("Statusword", "Velocity actual value")
        rpdo["Controlword"].raw = 0x0F
        rpdo["Target velocity"].raw = 600  # min⁻¹
        rpdo.transmit()
        up = self.samples(tpdo, names, lambda s: abs(s[1] - 600) <= 6 and s[0] & 0x0400)
        self.assertTrue(any(0 < v < 550 for _, v in up), f"accelerating on 0x6083: {up}")
        self.assertGreaterEqual(sum(0 < v < 550 for _, v in up), 3, f"a ramp of 0.1 s, not a step: {up}")
        moved = self.i32(0x6064)
        time.sleep(0.2)
        self.assertGreater(self.i32(0x6064) - moved, 65536, "600 min⁻¹ for 0.2 s: two revolutions")
        rpdo["Controlword"].raw = 0x0B
        rpdo.transmit()
        down = self.samples(tpdo, names, lambda s: s[1] == 0 and s[0] & 0x6F == 0x07, 1.0)
        self.assertGreaterEqual(sum(0 < v < 550 for _, v in down), 3, f"braking on the quick stop ramp 0x6085: {down}")
        self.assertEqual(self.drive.state, "QUICK STOP ACTIVE")
        held = self.i32(0x6064)
        time.sleep(0.1)
        self.assertLessEqual(abs(self.i32(0x6064) - held), 16, "stands")

    def test_guarding_loss_faults_the_drive_and_reset_from_fault(self):
        # 0x6007 = 1 on a guarding loss (D53; the b maXX has no heartbeat consumer): guard
        # time 50 ms x life time factor 2. python-canopen guards the node, then stops.
        self.drive.sdo[0x6007].raw = 1
        self.drive.sdo[0x100C].raw = 50
        self.drive.sdo[0x100D].raw = 2
        self.drive.state = "OPERATION ENABLED"
        self.drive.emcy.reset()
        self.drive.nmt.start_node_guarding(0.05)
        time.sleep(0.2)
        self.drive.nmt.stop_node_guarding()
        self.emcy(0x8130)  # life guarding
        self.wait_for("FAULT from TPDO1", lambda: self.drive.state == "FAULT", 1.0)
        self.assertEqual(self.drive.nmt.state, "OPERATIONAL", "answers of the guarding")
        self.drive.reset_from_fault()
        self.assertEqual(self.drive.state, "OPERATION ENABLED")
        self.assertEqual((self.drive.emcy.log[-1].code, self.drive.emcy.active), (0, []), "all acknowledged (B17)")

    def test_store_sub_2_and_restore_across_power_cycles(self):
        # 0x1010/0x1011 sub 1 is "not supported" (M-L1311, D10): python-canopen's default
        # store() is refused; sub 2 keeps the communication parameters, in Pre-operational.
        from canopen.sdo.exceptions import SdoAbortedError
        with self.assertRaises(SdoAbortedError) as e:
            self.drive.store()
        self.assertEqual(e.exception.code, 0x08000020)
        self.power_cycle_keeps_what_was_stored({(0x1803, 2): (1, 254), (0x1801, 5): (250, 0)}, store_sub=2)


if __name__ == "__main__":
    unittest.main()
