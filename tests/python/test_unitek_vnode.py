"""The UNITEK DS register protocol from python-can over SLCAN, against `vnode --device unitek-ds`
(the device's own application, as its image runs it): the session of unitek.py."""

import os
import unittest

from test_interop import ROOT, Vnode
from test_qemu_smoke import FrameLog
from unitek import session


class UnitekVnode(unittest.TestCase):
    def test_register_protocol_session(self):
        v = Vnode(device="unitek-ds", node_id=1, eds=os.path.join(ROOT, "firmware", "eds", "unitek-ds.eds"))
        self.addCleanup(v.close)
        frames = FrameLog()
        v.network.notifier.add_listener(frames)
        # vnode runs on the host's clock: 10 ms, give or take the host's wake-up delays.
        session(self, v.network.send_message, frames, wall_period=(0.007, 0.02), strict=False)


if __name__ == "__main__":
    unittest.main()
