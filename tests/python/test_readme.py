"""The README's python block for driving a drive ("Driving a drive from python") runs as printed.

vnode --device ec5000 --node-id 5 stands in for the drive; the block, with PORT replaced by the
port vnode took, runs in its own python from the repository's root and must print 100 (mm/s).
"""

import os
import re
import subprocess
import sys
import unittest

from test_interop import ROOT, Vnode


def readme_block():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        text = f.read()
    section = text.split("### Driving a drive from python", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


class ReadmeDrive(unittest.TestCase):
    def test_the_readme_block_turns_the_roller(self):
        v = Vnode(device="ec5000", node_id=5, eds=os.path.join(ROOT, "firmware", "eds", "ec5000.eds"))
        self.addCleanup(v.close)
        code = readme_block().replace("PORT", str(v.port))
        run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=30)
        self.assertEqual(run.returncode, 0, run.stderr)
        self.assertEqual(run.stdout.strip(), "100", run.stderr)


if __name__ == "__main__":
    unittest.main()
