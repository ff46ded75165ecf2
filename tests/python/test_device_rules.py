"""Device rules through python-canopen: each device's own application, as its image runs it, in `vnode`.

An independent master checks the rules of docs/devices/<device>.md (exact abort codes, read-back values).
"""

import os
import struct
import unittest

import canopen

from test_interop import ROOT, Vnode


def eds(name):
    return os.path.join(ROOT, "firmware", "eds", name + ".eds")


class DeviceRules(unittest.TestCase):
    def vnode(self, device, node_id):
        v = Vnode(device=device, node_id=node_id, eds=eds(device))
        self.addCleanup(v.close)
        v.node.sdo.upload(0x1000, 0)
        return v.node

    def assert_abort(self, code, fn, *args):
        with self.assertRaises(canopen.SdoAbortedError) as e:
            fn(*args)
        self.assertEqual(e.exception.code, code)

    def test_agile_0x1006_whole_milliseconds_d6(self):
        node = self.vnode("agile", 1)
        self.assert_abort(0x06090030, node.sdo.download, 0x1006, 0, struct.pack("<I", 1500))
        node.sdo.download(0x1006, 0, struct.pack("<I", 3000))
        self.assertEqual(node.sdo.upload(0x1006, 0), struct.pack("<I", 3000))

    def test_agile_data_set_0_writes_all_four_d25(self):
        node = self.vnode("agile", 1)
        node.sdo.download(0x2175, 0, struct.pack("<H", 12))
        for sub in range(1, 5):
            self.assertEqual(node.sdo.upload(0x2175, sub), struct.pack("<H", 12))

    def test_agile_data_sets_eeprom_and_ram_d49(self):
        # Without the EDS: python-canopen would cut the answer of sub 0 to the ARRAY's
        # UNSIGNED8 "highest sub-index", which the manual's data set 0 is not (D49).
        v = Vnode(device="agile", node_id=1, eds=canopen.ObjectDictionary())
        self.addCleanup(v.close)
        node = v.node
        node.sdo.download(0x2175, 0, struct.pack("<H", 3))
        self.assertEqual(node.sdo.upload(0x2175, 0), struct.pack("<H", 3), "data set 0: the four, equal")
        node.sdo.download(0x2175, 2, struct.pack("<H", 4))
        self.assert_abort(0x06040047, node.sdo.upload, 0x2175, 0)
        # Data set 2 in RAM (sub 7): the value the inverter uses, read at sub 2 and sub 7.
        node.sdo.download(0x2175, 7, struct.pack("<H", 5))
        self.assertEqual(node.sdo.upload(0x2175, 2), struct.pack("<H", 5))
        self.assertEqual(node.sdo.upload(0x2175, 7), struct.pack("<H", 5))
        # A one-value parameter has data set 0 (and 5 in RAM) only.
        node.sdo.download(0x2197, 5, struct.pack("<h", -5))
        self.assertEqual(node.sdo.upload(0x2197, 0), struct.pack("<h", -5))
        self.assert_abort(0x06090011, node.sdo.upload, 0x2197, 1)

    def test_ec5000_modes_and_polarity_d34_d35(self):
        node = self.vnode("ec5000", 5)
        self.assert_abort(0x06090030, node.sdo.download, 0x6060, 0, bytes([2]))
        node.sdo.download(0x6060, 0, bytes([3]))
        self.assert_abort(0x06090030, node.sdo.download, 0x607E, 0, bytes([0x20]))
        node.sdo.download(0x607E, 0, bytes([0xC0]))

    def test_ec5000_active_node_id_d31_and_ssw_save_f8(self):
        node = self.vnode("ec5000", 5)
        self.assertEqual(node.sdo.upload(0x4650, 2), bytes([5]))
        node.sdo.download(0x1010, 5, b"save")
        node.sdo.download(0x1011, 5, b"load")

    def test_sendix_cyclic_timer_is_tpdo1_event_timer_d11(self):
        node = self.vnode("sendix", 0x3F)
        node.sdo.download(0x6200, 0, struct.pack("<H", 100))
        self.assertEqual(node.sdo.upload(0x1800, 5), struct.pack("<H", 100))
        node.sdo.download(0x1800, 5, struct.pack("<H", 40))
        self.assertEqual(node.sdo.upload(0x6200, 0), struct.pack("<H", 40))

    def test_sendix_100_kbit_refused_and_device_type_d2(self):
        node = self.vnode("sendix", 0x3F)
        self.assert_abort(0x06090030, node.sdo.download, 0x2100, 0, bytes([3]))
        self.assertEqual(node.sdo.upload(0x1000, 0), struct.pack("<I", 0x000B0196))

    def test_bmaxx_mapping_while_valid_and_one_byte_heartbeat_d27_d9(self):
        node = self.vnode("bmaxx4400", 2)
        node.sdo.download(0x1A00, 1, struct.pack("<I", 0x60860010))
        node.sdo.download(0x1A00, 2, struct.pack("<I", 0x60440010))
        node.sdo.download(0x1A00, 0, bytes([2]))
        self.assertEqual(node.sdo.upload(0x1A00, 1), struct.pack("<I", 0x60860010))
        node.sdo.download(0x1017, 0, bytes([100]))
        self.assertEqual(node.sdo.upload(0x1017, 0), struct.pack("<H", 100))


if __name__ == "__main__":
    unittest.main()
