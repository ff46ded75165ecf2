"""The Baumüller b maXX 4400 synchronised to the SYNC, seen by python-canopen (docs/devices/bmaxx4400.md D66).

With a SYNC interval in 0x1006 the drive's position control (interpolated position, 7) follows the SYNC: when
python-canopen's periodic SYNC stops, the drive reports drive error 00A5h "Regler nicht synchron zu externem
Signal" as EMCY 8100h (the number in the manufacturer-specific field) and enters FAULT. With P0830 bit 6 ("Reset
der Synchronisation nach einem SYNC-Telegrammausfall") it is in step again with the first SYNC back, so
a fault reset (BaseNode402's transition 15) acknowledges the error ("error reset", no active error left). The SYNC interval is 8 ms:
with the PLL a SYNC may be 4 ms off, which a loaded machine keeps; an earlier trip would give the same EMCY.
"""

import os
import struct
import time
import unittest

from drive402 import Drive402Test
from test_interop import ROOT


class Bmaxx4400Sync(Drive402Test):
    DEVICE, NODE_ID = "bmaxx4400", 4
    EDS = os.path.join(ROOT, "firmware", "eds", "bmaxx4400.eds")

    def test_a_sync_loss_in_ip_is_emcy_8100_drive_error_00a5_and_bit_6_lets_a_fault_reset_acknowledge_it(self):
        self.drive.sdo[0x433E].raw = 0x0040  # P0830 bit 6
        self.drive.sdo[0x1006].raw = 8000
        self.drive.sdo.download(0x6060, 0, struct.pack("<b", 7))
        self.addCleanup(self.v.network.sync.stop)
        self.v.network.sync.start(0.008)
        self.drive.state = "OPERATION ENABLED"
        self.drive.controlword = 0x1F
        time.sleep(0.2)
        self.v.network.sync.stop()
        self.wait_for("EMCY 8100h", lambda: any(e.code == 0x8100 for e in self.drive.emcy.log))
        error = next(e for e in self.drive.emcy.log if e.code == 0x8100)
        self.assertEqual(error.data, bytes([0x00, 0xA5, 0x00, 0x00, 0x00]))
        self.wait_for("FAULT", lambda: self.drive.sdo[0x6041].raw & 0x4F == 0x08)
        self.v.network.sync.start(0.008)
        time.sleep(0.05)
        self.drive.state = "SWITCH ON DISABLED"  # transition 15: the fault reset
        self.assertEqual(self.drive.sdo[0x6041].raw & 0x4F, 0x40)
        self.wait_for("error reset", lambda: not self.drive.emcy.active)


if __name__ == "__main__":
    unittest.main()
