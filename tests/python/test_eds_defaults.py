"""Each device's EDS tells the truth about its power-on values, as python-canopen reads them.

A configuration tool takes an EDS DefaultValue for the value the device starts with (and writes
it back to "restore the defaults"). So every object an SDO upload answers right after the start
must hold its EDS DefaultValue, but for the live values listed here (measurements, the
statusword, the turning shaft) and the Agile's data-set parameters, whose sub 0 is data set 0
(docs/devices/agile.md D49).
"""

import os
import unittest

import canopen

from test_interop import ROOT, Vnode

# (device, node-id, {(index, sub): why the value is live}); the EC5000 runs at its factory node-id
# 127, which its EDS gives 0x4650:02 "Node-ID actual".
CASES = [
    ("ec5000", 127, {(0x2200, 4): "temperature", (0x2200, 5): "temperature", (0x2200, 6): "temperature",
                     (0x6041, 0): "statusword"}),
    ("sendix", 5, {(0x2150, 0): "temperature", (0x2162, 0): "CRC of the raw position", (0x6004, 0): "position",
                   (0x600B, 0): "raw position", (0x600C, 0): "raw position", (0x6030, 1): "speed",
                   (0x6040, 1): "acceleration"}),
    ("bmaxx4400", 5, {(0x1002, 0): "status register", (0x412D, 0): "P0301 = statusword", (0x6041, 0): "statusword"}),
    ("agile", 5, {(0x250A, 0): "NMT state", (0x6041, 0): "statusword", (0x6079, 0): "DC link voltage"}),
    ("interop", 5, {}),
]


def entries(od):
    for obj in od.values():
        if isinstance(obj, canopen.objectdictionary.ODVariable):
            yield obj
        else:
            yield from obj.values()


class EdsDefaults(unittest.TestCase):
    def test_power_on_values_are_the_eds_defaults(self):
        for device, node_id, live in CASES:
            with self.subTest(device=device):
                eds = os.path.join(ROOT, "tests" if device == "interop" else "firmware", "eds", device + ".eds")
                v = Vnode(device=device, node_id=node_id, eds=eds)
                try:
                    wrong = []
                    for var in entries(v.node.object_dictionary):
                        if var.default is None or (var.index, var.subindex) in live:
                            continue
                        data_set_0 = (device == "agile" and 0x2000 <= var.index < 0x3000 and var.subindex == 0
                                      and isinstance(var.parent, canopen.objectdictionary.ODArray))
                        if data_set_0:
                            continue
                        try:
                            data = v.node.sdo.upload(var.index, var.subindex)
                        except canopen.SdoAbortedError:
                            continue  # write-only: no value to compare
                        if data != var.encode_raw(var.default):
                            wrong.append(f"0x{var.index:04X}:{var.subindex:02X} {var.name}: EDS {var.default!r}, "
                                         f"device {data.hex()}")
                    self.assertEqual(wrong, [])
                finally:
                    v.close()


if __name__ == "__main__":
    unittest.main()
