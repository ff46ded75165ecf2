"""`tests/python/hil.py` (`cargo xtask hil`) against vnode: a node-id that
answers nothing is reported as a failed boot-up and the check stops with a
hint, exit status 1, instead of a python traceback after minutes of SDO
timeouts; without a power cycle (stdin closed, no --power-cycle-command)
the check says how to give one and skips what needs it. Runs with the venv `cargo xtask test` creates:
    .venv/bin/python -m unittest tests/python/test_hil.py -v
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VNODE = os.environ.get("VNODE", os.path.join(ROOT, "target", "debug", "vnode"))
HIL = os.path.join(ROOT, "tests", "python", "hil.py")


class HilTest(unittest.TestCase):
    def _sendix_vnode(self, stop):
        """A Sendix vnode (node 63) on an ephemeral port, ended at cleanup by
        its `stop` method ("terminate", or "kill" where the test kills it)."""
        vnode = subprocess.Popen([VNODE, "--device", "sendix", "--node-id", "63", "--listen", "127.0.0.1:0"],
                                 stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self.addCleanup(vnode.stdout.close)
        self.addCleanup(vnode.wait, 5)
        self.addCleanup(getattr(vnode, stop))
        port = int(re.search(r":(\d+)\s*$", vnode.stdout.readline()).group(1))
        return vnode, port

    def test_a_node_id_that_answers_nothing_stops_with_a_hint(self):
        vnode, port = self._sendix_vnode(stop="terminate")
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


    def test_no_one_to_cycle_the_power_is_a_failed_check_not_a_traceback(self):
        # The whole check against vnode, stdin closed: the power cycle cannot
        # happen, and what depends on it is skipped, not passed.
        vnode, port = self._sendix_vnode(stop="terminate")
        out = subprocess.run([sys.executable, HIL, "--interface", "slcan", "--channel", f"socket://127.0.0.1:{port}",
                              "--bitrate", "1000000", "--device", "sendix", "--node-id", "63"],
                             stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
        self.assertEqual(out.returncode, 1, out.stdout + out.stderr)
        self.assertIn("PASS  TPDO1 0x1BF carries its mapped objects", out.stdout)
        self.assertIn("give --power-cycle-command", out.stdout)
        self.assertIn("FAIL  boot-up after the power cycle", out.stdout)
        self.assertIn("SKIP  0x1017 after the power cycle (there was none)", out.stdout)
        self.assertIn("1 check(s) failed", out.stdout)
        self.assertNotIn("Traceback", out.stderr)


    def test_a_connection_that_drops_is_one_line_not_a_traceback(self):
        # The power cycle ends vnode, as a QEMU that dies ends the link:
        # python-can's receive thread meets the closed connection. That is
        # one line on stderr, and the checks that follow fail as FAIL lines.
        vnode, port = self._sendix_vnode(stop="kill")
        out = subprocess.run([sys.executable, HIL, "--interface", "slcan", "--channel", f"socket://127.0.0.1:{port}",
                              "--bitrate", "1000000", "--device", "sendix", "--node-id", "63",
                              "--power-cycle-command", f"kill {vnode.pid}"],
                             stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=90)
        self.assertEqual(out.returncode, 1, out.stdout + out.stderr)
        self.assertIn("FAIL  boot-up after the power cycle", out.stdout)
        self.assertNotIn("Traceback", out.stderr)
        lines = out.stderr.splitlines()
        self.assertEqual(len(lines), 1, out.stderr)
        self.assertTrue(lines[0].startswith("hil.py: the connection to the bus ended: "), out.stderr)

    @unittest.skipUnless(shutil.which("qemu-system-arm"), "qemu-system-arm is not installed")
    def test_an_image_qemu_cannot_run_is_a_failed_check_and_leaves_no_folder(self):
        # The folder of the storage file and the defmt log goes with the run
        # (each `cargo xtask test` left four in /tmp), also when QEMU fails:
        # here it opens its serial port and then finds no kernel to load.
        tmp = tempfile.mkdtemp(prefix="test-hil-")
        self.addCleanup(shutil.rmtree, tmp, True)
        out = subprocess.run([sys.executable, HIL, "--qemu", os.path.join(tmp, "no-such-image.elf"), "--device", "sendix",
                              "--node-id", "63"], capture_output=True, text=True, timeout=60, env={**os.environ, "TMPDIR": tmp})
        self.assertEqual(out.returncode, 1, out.stdout + out.stderr)
        self.assertIn("FAIL  ", out.stdout)
        self.assertEqual(os.listdir(tmp), [])


if __name__ == "__main__":
    unittest.main()
