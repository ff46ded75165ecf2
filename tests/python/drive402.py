"""What the CiA 402 tests share: a drive in `vnode` driven by python-canopen's BaseNode402.

A subclass names `DEVICE`, `NODE_ID` and `EDS`; `setUp` starts vnode, attaches the drive,
gives each TPDO of `EVENT_TIMED_TPDOS` a 100 ms event timer (BaseNode402 takes a TPDO it has
seen twice as periodic and then waits at most 0.2 s for the next one), switches the TPDOs of
`OFF_TPDOS` off (so that BaseNode402 takes the statusword from a synchronous TPDO instead), sets
up the state machine and starts the node. `STATE_CHANGE` is the most a state change may take:
half of BaseNode402's 0.4 s, which the drives answer well inside.
"""

import time
import unittest

from canopen.profiles.p402 import BaseNode402

from test_interop import Vnode


class Drive402Test(unittest.TestCase):
    DEVICE = None
    NODE_ID = None
    EDS = None
    EVENT_TIMED_TPDOS = (0x1800,)
    OFF_TPDOS = ()
    STATE_CHANGE = 0.2

    def setUp(self):
        self.v = Vnode(device=self.DEVICE, node_id=self.NODE_ID, eds=self.EDS)
        self.addCleanup(self.v.close)
        self.v.network.nodes.pop(self.NODE_ID, None)
        self.drive = BaseNode402(self.NODE_ID, self.EDS)
        self.v.network.add_node(self.drive)
        self.drive.sdo.RESPONSE_TIMEOUT = 2.0
        self.drive.sdo.upload(0x1000, 0)
        self.drive.nmt.state = "PRE-OPERATIONAL"
        for tpdo in self.EVENT_TIMED_TPDOS:
            self.drive.sdo[tpdo][5].raw = 100
        for tpdo in self.OFF_TPDOS:
            self.drive.sdo[tpdo][1].raw = self.drive.sdo[tpdo][1].raw | 0x80000000
        self.drive.setup_402_state_machine()
        self.drive.nmt.state = "OPERATIONAL"

    def wait_for(self, what, condition, timeout=3.0):
        end = time.monotonic() + timeout
        while not condition():
            self.assertLess(time.monotonic(), end, what)
            time.sleep(0.01)
