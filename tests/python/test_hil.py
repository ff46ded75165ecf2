"""`tests/python/hil.py` (`cargo xtask hil`) against vnode: a node-id that
answers nothing is reported as a failed boot-up and the check stops with a
hint, exit status 1, instead of a python traceback after minutes of SDO
timeouts. Runs with the venv `cargo xtask test` creates:
    .venv/bin/python -m unittest tests/python/test_hil.py -v
"""

import os
import re
import subprocess
import sys
import time
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VNODE = os.environ.get("VNODE", os.path.join(ROOT, "target", "debug", "vnode"))
HIL = os.path.join(ROOT, "tests", "python", "hil.py")


class HilTest(unittest.TestCase):
    def test_a_node_id_that_answers_nothing_stops_with_a_hint(self):
        vnode = subprocess.Popen([VNODE, "--device", "sendix", "--node-id", "63", "--listen", "127.0.0.1:0"],
                                 stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self.addCleanup(vnode.wait, 5)
        self.addCleanup(vnode.terminate)
        port = int(re.search(r":(\d+)\s*$", vnode.stdout.readline()).group(1))
        start = time.monotonic()
        out = subprocess.run([sys.executable, HIL, "--interface", "slcan", "--channel", f"socket://127.0.0.1:{port}",
                              "--bitrate", "1000000", "--device", "sendix", "--node-id", "62"],
                             capture_output=True, text=True, timeout=60)
        self.assertEqual(out.returncode, 1, out.stdout + out.stderr)
        self.assertIn("FAIL  boot-up 0x73E [00]", out.stdout)
        self.assertIn("stopped: node 62 sent no boot-up", out.stdout)
        self.assertNotIn("Traceback", out.stderr)
        # Boot-up wait, NMT reset node and its wait: no SDO timeouts after them.
        self.assertLess(time.monotonic() - start, 15)


if __name__ == "__main__":
    unittest.main()
