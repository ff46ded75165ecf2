"""The Bonfiglioli Agile's bus faults as python-canopen sees them: an RPDO of a wrong length.

"RxPDO1 Längenfehler (Anzahl der empfangenen Bytes … abweichend vom Mapping)" is the inverter's
fault F20.26 with 0x6007's reaction (factory 1: Fault at once), the key 0x2026 in EMCY bytes 6-7
beside CiA 301's own 0x8210 (docs/devices/agile.md D60); the next RPDO of the right length resets
it through BaseNode402 (D58).
"""

import os
import unittest

from drive402 import Drive402Test
from test_interop import ROOT

EDS = os.path.join(ROOT, "firmware", "eds", "agile.eds")


class AgileRpdoLength(Drive402Test):
    DEVICE, NODE_ID, EDS = "agile", 1, EDS

    def test_a_short_rpdo1_is_f20_26_and_faults(self):
        self.drive.state = "OPERATION ENABLED"
        self.drive.emcy.reset()
        # RPDO1 maps 0x6040 + 0x6042, 4 bytes: three are a length error.
        self.v.network.send_message(0x200 + self.NODE_ID, b"\x0f\x00\xdc")
        codes = lambda: [e.code for e in self.drive.emcy.log]
        self.wait_for("EMCY 0x8210 and 0x1000", lambda: 0x8210 in codes() and 0x1000 in codes())
        fault = next(e for e in self.drive.emcy.log if e.code == 0x1000)
        self.assertEqual(fault.data[3:5], b"\x26\x20", "fault key F20.26 in bytes 6-7")
        self.wait_for("Fault", lambda: self.drive.sdo[0x6041].raw & 0x4F == 0x08)
        self.assertEqual(self.drive.sdo[0x2104].raw, 0x2026, "p.260 current fault")
        # BaseNode402's fault reset goes by RPDO1 of the right length: processed again.
        self.drive.state = "SWITCH ON DISABLED"
        self.assertEqual(self.drive.sdo[0x6041].raw & 0x4F, 0x40)


if __name__ == "__main__":
    unittest.main()
