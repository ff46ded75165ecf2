"""What the CiA 402 tests share: a drive in `vnode` driven by python-canopen's BaseNode402.

A subclass names `DEVICE`, `NODE_ID` and `EDS`; `setUp` starts vnode, attaches the drive,
gives each TPDO of `EVENT_TIMED_TPDOS` a 100 ms event timer (BaseNode402 takes a TPDO it has
seen twice as periodic and then waits at most 0.2 s for the next one), switches the TPDOs of
`OFF_TPDOS` off (so that BaseNode402 takes the statusword from a synchronous TPDO instead), sets
up the state machine and starts the node. `STATE_CHANGE` is the most a state change may take:
half of BaseNode402's 0.4 s, which the drives answer well inside.

`walk_the_state_machine` takes the drive through every state change BaseNode402 makes, each
within `STATE_CHANGE`. The helpers play what a PLC programmer does with python-canopen beyond the state machine:
`samples` reads a TPDO as it arrives, `fault_by_heartbeat_loss` lets the PLC's heartbeat
stop (the drive's consumer 0x1016 times out) and waits for the EMCY with python-canopen's
EMCY consumer, `power_cycle_keeps_what_was_stored` stores with `node.store()`, restarts vnode on
the same storage file and restores with `node.restore()`.
"""

import os
import shutil
import struct
import tempfile
import time
import unittest

from canopen.profiles.p402 import BaseNode402

from test_interop import Vnode

# The PLC's node-id for its heartbeat.
PLC = 0x7F


class Drive402Test(unittest.TestCase):
    DEVICE = None
    NODE_ID = None
    EDS = None
    EVENT_TIMED_TPDOS = (0x1800,)
    OFF_TPDOS = ()
    STATE_CHANGE = 0.2

    def setUp(self):
        self.v, self.drive = self.attach()
        self.drive.nmt.state = "PRE-OPERATIONAL"
        for tpdo in self.EVENT_TIMED_TPDOS:
            self.drive.sdo[tpdo][5].raw = 100
        for tpdo in self.OFF_TPDOS:
            self.drive.sdo[tpdo][1].raw = self.drive.sdo[tpdo][1].raw | 0x80000000
        self.drive.setup_402_state_machine()
        self.drive.nmt.state = "OPERATIONAL"

    def attach(self, extra=()):
        """Starts a vnode of the drive and attaches a BaseNode402 to it; closed at the test's end."""
        v = Vnode(device=self.DEVICE, node_id=self.NODE_ID, eds=self.EDS, extra=extra)
        self.addCleanup(v.close)
        v.network.nodes.pop(self.NODE_ID, None)
        drive = BaseNode402(self.NODE_ID, self.EDS)
        v.network.add_node(drive)
        drive.sdo.RESPONSE_TIMEOUT = 2.0
        drive.sdo.upload(0x1000, 0)
        return v, drive

    def walk_the_state_machine(self):
        """From SWITCH ON DISABLED (0x6041 & 0x4F = 0x40) through every state change BaseNode402
        makes by 0x6040, each read back from 0x6041 within `STATE_CHANGE`."""
        self.assertEqual(self.drive.sdo[0x6041].raw & 0x4F, 0x40)
        for state in ["READY TO SWITCH ON", "SWITCHED ON", "OPERATION ENABLED", "SWITCHED ON",
                      "READY TO SWITCH ON", "SWITCH ON DISABLED", "OPERATION ENABLED"]:
            start = time.monotonic()
            self.drive.state = state
            self.assertEqual(self.drive.state, state)
            self.assertLess(time.monotonic() - start, self.STATE_CHANGE, state)

    def i32(self, index):
        """An INTEGER32 object's value (sub 0), uploaded by SDO."""
        return struct.unpack("<i", self.drive.sdo.upload(index, 0))[0]

    def wait_for(self, what, condition, timeout=3.0):
        end = time.monotonic() + timeout
        while not condition():
            self.assertLess(time.monotonic(), end, what)
            time.sleep(0.01)

    def samples(self, pdo, names, until, timeout=3.0):
        """Each reception of `pdo` as a tuple of the named variables, until `until(tuple)` holds."""
        seen = []
        end = time.monotonic() + timeout
        while not seen or not until(seen[-1]):
            self.assertLess(time.monotonic(), end, f"{names}: {seen[-5:]}")
            if pdo.wait_for_reception(0.5) is not None:
                seen.append(tuple(pdo[name].raw for name in names))
        return seen

    def fault_by_heartbeat_loss(self, code, consumer_ms=100):
        """The PLC's heartbeat is consumed by the drive, then stops: the drive faults (0x6007 = 1).

        Returns the EMCY python-canopen's consumer took with `code`.
        """
        self.drive.sdo[0x6007].raw = 1
        self.drive.sdo[0x1016][1].raw = (PLC << 16) | consumer_ms
        self.drive.emcy.reset()
        # One heartbeat (Operational) arms the consumer; none follows.
        self.v.network.send_message(0x700 + PLC, bytes([0x05]))
        return self.emcy(code)

    def emcy(self, code, timeout=1.0):
        """The EMCY with `code`: from python-canopen's log if it came already, else by its
        `emcy.wait`, and from the log again: each time `wait` wakes it looks at the newest EMCY
        only, so of two that arrive together (the Agile's 0x8130 and 0x1000) it misses the first."""
        def logged():
            return next((e for e in self.drive.emcy.log if e.code == code), None)

        emcy = logged() or self.drive.emcy.wait(code, timeout) or logged()
        self.assertIsNotNone(emcy, f"EMCY {code:#06x} {self.drive.emcy.log}")
        return emcy

    def power_cycle_keeps_what_was_stored(self, values, store_sub=1, heartbeat_ms=50):
        """Writes `values` ({(index, sub): (new, default)}) and the heartbeat time 0x1017, stores
        them with `node.store(store_sub)` in Pre-operational, powers the drive off and on (a new
        vnode on the same storage file), reads them back, restores the defaults with
        `node.restore(store_sub)` and powers it off and on again (CiA 301: the defaults take
        effect at the next reset or power-on).
        """
        folder = tempfile.mkdtemp(prefix="drive402")
        self.addCleanup(shutil.rmtree, folder)
        storage = ("--storage", os.path.join(folder, "flash"))
        values = {**values, (0x1017, None): (heartbeat_ms, 0)}

        def read(drive, key):
            return drive.sdo[key[0]].raw if key[1] is None else drive.sdo[key[0]][key[1]].raw

        v, drive = self.attach(storage)
        drive.nmt.state = "PRE-OPERATIONAL"
        for (index, sub), (new, _) in values.items():
            target = drive.sdo[index] if sub is None else drive.sdo[index][sub]
            target.raw = new
        drive.store(store_sub)
        v.close()
        v, drive = self.attach(storage)
        # The stored heartbeat runs from power-on: python-canopen learns the NMT state from it.
        self.assertEqual(drive.nmt.wait_for_heartbeat(1.0), "PRE-OPERATIONAL")
        self.assertEqual({key: read(drive, key) for key in values}, {key: new for key, (new, _) in values.items()})
        drive.restore(store_sub)
        v.close()
        v, drive = self.attach(storage)
        self.assertEqual({key: read(drive, key) for key in values}, {key: old for key, (_, old) in values.items()})
