"""CiA 402 velocity mode through python-canopen's BaseNode402: the Bonfiglioli Agile in `vnode`.

State changes by RPDO1 (0x6040, 0x6042) within BaseNode402's timeouts, and a vl move measured
by 0x6044 as the ramps 0x6048/0x6049 give it. 0x6060 is write-only and fixed to 2, and the
dictionary has no 0x6502, so the mode is not set through `op_mode` (docs/devices/agile.md D43).
"""

import os
import struct
import time
import unittest

from drive402 import PLC, Drive402Test
from test_interop import ROOT

EDS = os.path.join(ROOT, "firmware", "eds", "agile.eds")
NODE_ID = 1


class AgileVl(Drive402Test):
    DEVICE, NODE_ID, EDS = "agile", NODE_ID, EDS
    EVENT_TIMED_TPDOS = (0x1800,)

    def rpm(self, index):
        return struct.unpack("<h", self.drive.sdo.upload(index, 0))[0]

    def test_state_changes_through_the_state_machine(self):
        self.assertEqual(self.drive.sdo[0x6061].raw, 2, "velocity mode")
        self.walk_the_state_machine()

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


    # ---- as a PLC programmer uses python-canopen beyond BaseNode402's state machine ----

    def test_op_mode_reads_vl_and_its_setter_needs_0x6502(self):
        # The getter falls back to an SDO read of 0x6061 (in no TPDO); the setter asks 0x6502
        # first, which the Agile does not have (docs/devices/agile.md), and raises KeyError.
        self.assertEqual(self.drive.op_mode, "VELOCITY")
        with self.assertRaises(KeyError):
            self.drive.op_mode = "VELOCITY"

    def test_synchronous_rpdo1_is_taken_at_sync_and_tpdo2_the_plc_mapped(self):
        # The PLC makes RPDO1 synchronous (types 1-240: taken at every SYNC, §1.9) and maps
        # TPDO2 (off by default) to the statusword and 0x6044, synchronous; python-canopen
        # sends the periodic RPDO1 itself (`start`), and BaseNode402 writes into it.
        self.drive.nmt.state = "PRE-OPERATIONAL"
        self.drive.rpdo[1].trans_type = 1
        self.drive.rpdo[1].save()
        tpdo = self.drive.tpdo[2]
        tpdo.clear()
        tpdo.add_variable("Statusword")
        tpdo.add_variable("vl control effort")
        tpdo.trans_type = 1
        tpdo.enabled = True
        tpdo.save()
        self.drive.nmt.state = "OPERATIONAL"
        self.drive.sdo[0x6048][1].raw = 3000
        self.drive.sdo[0x604A][1].raw = 6000
        rpdo = self.drive.rpdo[1]
        rpdo["Controlword"].raw = 0x06
        rpdo["vl target velocity"].raw = 0
        rpdo.start(0.01)
        self.addCleanup(rpdo.stop)
        time.sleep(0.1)
        self.assertEqual(self.drive.sdo[0x6041].raw & 0x4F, 0x40, "no SYNC: the shutdown not taken yet")
        self.v.network.sync.start(0.01)
        self.addCleanup(self.v.network.sync.stop)
        self.drive.state = "OPERATION ENABLED"
        rpdo["vl target velocity"].raw = 600
        names = ("Statusword", "vl control effort")
        up = self.samples(tpdo, names, lambda s: s[1] == 600 and s[0] & 0x0400)
        self.assertGreaterEqual(sum(0 < v < 570 for _, v in up), 3, f"on the ramp (0.2 s): {up}")
        # Quick stop on 0x604A (6000 min⁻¹/s: 0.1 s), then Switch on disabled.
        rpdo["Controlword"].raw = 0x0B
        down = self.samples(tpdo, names, lambda s: s[0] & 0x4F == 0x40, 1.0)
        self.assertGreaterEqual(sum(0 < v < 570 for _, v in down), 3, f"braking on 0x604A (0.1 s): {down}")
        self.assertEqual(down[-1][1], 0)

    def test_heartbeat_loss_faults_f23_and_reset_from_fault_sends_the_zero_emcy(self):
        # 0x6007 = 1 is the factory setting (p.388 = 1): the PLC's heartbeat lost faults the
        # drive with 0x8130 and the inverter's 0x1000 carrying F23.<node> (D44).
        self.drive.sdo[0x1017].raw = 50
        self.drive.state = "OPERATION ENABLED"
        self.fault_by_heartbeat_loss(0x8130)
        self.wait_for("EMCY 0x1000 F23.7F", lambda: any(
            e.code == 0x1000 and e.data == bytes([0, 0, 0, PLC, 0x23]) for e in self.drive.emcy.log), 1.0)
        self.assertEqual(self.drive.sdo[0x603F].raw, 0x1000)
        # 0x1029 sub 1 = 0: Pre-operational, as the heartbeat shows; the PLC is back, with its
        # heartbeat every 50 ms.
        self.assertEqual(self.drive.nmt.wait_for_heartbeat(0.5), "PRE-OPERATIONAL")
        heartbeat = self.v.network.send_periodic(0x700 + PLC, bytes([0x05]), 0.05)
        self.addCleanup(heartbeat.stop)
        self.drive.nmt.state = "OPERATIONAL"
        self.wait_for("FAULT", lambda: self.drive.state == "FAULT", 1.0)
        self.drive.emcy.reset()
        self.drive.reset_from_fault()
        self.assertEqual(self.drive.state, "OPERATION ENABLED")
        self.wait_for("the all-zero EMCY (M-L838)", lambda: any(
            e.code == 0 and e.register == 0 and e.data == bytes(5) for e in self.drive.emcy.log), 0.5)

    def test_store_and_restore_across_power_cycles(self):
        # 0x1010/0x1011 sub 1 (D7); the ramps 0x6048/0x6049 sub 1 (factory 150 min⁻¹ per s).
        self.power_cycle_keeps_what_was_stored({(0x6048, 1): (3000, 150), (0x6049, 1): (2000, 150)})


if __name__ == "__main__":
    unittest.main()
