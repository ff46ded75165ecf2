"""Interop: python-canopen's LSS master (`network.lss`) against `vnode` over SLCAN.

An unconfigured EC5000 (`--node-id 255`) with a serial number is found by
fastscan, given a node-id, stored, inquired, and boots with the stored
node-id at the next start (`--storage FILE`).
"""

import os
import tempfile
import time
import unittest

import canopen
from canopen.lss import CS_INQUIRE_SERIAL_NUMBER, CS_INQUIRE_VENDOR_ID

import test_interop
from test_interop import ROOT

EC5000_EDS = os.path.join(ROOT, "firmware", "eds", "ec5000.eds")
SERIAL = 0x00C0FFEE


class Vnode(test_interop.Vnode):
    """An EC5000 with a serial number on `storage`, at 250 kbit/s; no node added (LSS finds it)."""

    def __init__(self, storage, node_id=255):
        super().__init__(device="ec5000", node_id=node_id, eds=None, bitrate=250000,
                         extra=("--serial", str(SERIAL), "--storage", storage))
        # Fastscan reads a missing answer as a bit: the wait must outlast a
        # loaded machine's scheduling delay (0.1 s did not, once in CI-like
        # load), yet stay below python-canopen's 0.5 s to keep the scan short.
        self.network.lss.RESPONSE_TIMEOUT = 0.3


class LssTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.storage = os.path.join(self.dir.name, "flash.bin")

    def tearDown(self):
        self.dir.cleanup()

    def test_fastscan_configure_store_inquire_and_restart(self):
        v = Vnode(self.storage)
        try:
            lss = v.network.lss
            found, address = lss.fast_scan()
            self.assertTrue(found)
            self.assertEqual(address[3], SERIAL)
            self.assertEqual(address[0], 0x3FB)  # EC5000 vendor-ID (docs/devices/ec5000.md)
            # Fastscan left the drive in the configuration state.
            self.assertEqual(lss.inquire_lss_address(CS_INQUIRE_SERIAL_NUMBER), SERIAL)
            self.assertEqual(lss.inquire_lss_address(CS_INQUIRE_VENDOR_ID), 0x3FB)
            self.assertEqual(lss.inquire_node_id(), 0xFF)
            lss.configure_node_id(10)
            lss.store_configuration()
            node = v.network.add_node(10, EC5000_EDS)
            # Leaving the configuration state starts the drive as node 10; frames on one
            # link stay in order, so the SDO answer proves it started.
            lss.send_switch_state_global(lss.WAITING_STATE)
            self.assertEqual(node.sdo[0x1018][4].raw, SERIAL)
            lss.send_switch_state_global(lss.CONFIGURATION_STATE)
            self.assertEqual(lss.inquire_node_id(), 10)
            lss.send_switch_state_global(lss.WAITING_STATE)
        finally:
            v.close()
        # The stored configuration is used at the next start.
        v = Vnode(self.storage)
        try:
            node = v.network.add_node(10, EC5000_EDS)
            self.assertEqual(node.sdo[0x1018][4].raw, SERIAL)
            found, _ = v.network.lss.fast_scan()
            self.assertFalse(found, "a configured node does not take part in fastscan")
        finally:
            v.close()

    def test_at_the_factory_node_id_127_the_new_node_id_is_active_on_leaving_configuration(self):
        # docs/devices/ec5000.md: "temporär aktiv" (manual L219/L234), no NMT reset needed; not stored.
        v = Vnode(self.storage, node_id=127)
        try:
            lss = v.network.lss
            lss.send_switch_state_global(lss.CONFIGURATION_STATE)
            lss.configure_node_id(12)
            node = v.network.add_node(12, EC5000_EDS)
            node.sdo.RESPONSE_TIMEOUT = 1.0
            lss.send_switch_state_global(lss.WAITING_STATE)
            self.assertEqual(node.sdo[0x4650][2].raw, 12, "NodeID Actual")
        finally:
            v.close()
        v = Vnode(self.storage, node_id=127)
        try:
            node = v.network.add_node(127, EC5000_EDS)
            self.assertEqual(node.sdo[0x4650][2].raw, 127, "not stored: back to 127 after a restart")
        finally:
            v.close()

    def test_configuration_errors(self):
        v = Vnode(self.storage, node_id=5)
        try:
            lss = v.network.lss
            lss.send_switch_state_global(lss.CONFIGURATION_STATE)
            with self.assertRaises(canopen.lss.LssError):
                lss.configure_node_id(0x80)
            with self.assertRaises(canopen.lss.LssError):
                lss.configure_bit_timing(0)  # 1 Mbit/s: the EC5000 supports 125 and 250 kbit/s only
            lss.configure_bit_timing(4)
            self.assertEqual(lss.inquire_node_id(), 5)
        finally:
            v.close()

    def test_identify_remote_slave_answers_inside_the_range_only(self):
        """CiA 305 §5.5 identify remote slave, as raw frames on 0x7E5 (python-canopen's
        `send_identify_remote_slave` returns no answer): vendor-id and product code equal,
        revision and serial number within their bounds, each bound inclusive."""
        v = Vnode(self.storage, node_id=5)
        try:
            lss = v.network.lss
            lss.send_switch_state_global(lss.CONFIGURATION_STATE)
            vendor, product, revision, serial = (lss.inquire_lss_address(cs) for cs in (0x5A, 0x5B, 0x5C, 0x5D))
            lss.send_switch_state_global(lss.WAITING_STATE)
            self.assertEqual((vendor, serial), (0x3FB, SERIAL))
            answers = []
            v.network.subscribe(0x7E4, lambda can_id, data, ts: answers.append(bytes(data)))

            def identify(bounds):
                answers.clear()
                for cs, value in zip(range(0x46, 0x4C), bounds):
                    v.network.send_message(0x7E5, bytes([cs]) + value.to_bytes(4, "little") + bytes(3))
                # An answer comes within milliseconds; 0.5 s without one (a loaded machine) is none.
                deadline = time.monotonic() + 0.5
                while not answers and time.monotonic() < deadline:
                    time.sleep(0.01)
                time.sleep(0.05)
                return answers[:]

            inside = [vendor, product, revision, revision, serial, serial]
            self.assertEqual(identify(inside), [bytes([0x4F]) + bytes(7)])
            self.assertEqual(identify([vendor, product, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF]), [bytes([0x4F]) + bytes(7)])
            outside = [
                [vendor + 1, product, revision, revision, serial, serial],
                [vendor, product + 1, revision, revision, serial, serial],
                [vendor, product, revision + 1, revision + 1, serial, serial],
                [vendor, product, revision - 1, revision - 1, serial, serial],
                [vendor, product, revision, revision, serial + 1, 0xFFFFFFFF],
                [vendor, product, revision, revision, 0, serial - 1],
            ]
            for bounds in outside:
                with self.subTest(bounds=[hex(b) for b in bounds]):
                    self.assertEqual(identify(bounds), [])
                    # A new sequence (from the vendor-id) is judged on its own.
                    self.assertEqual(identify(inside), [bytes([0x4F]) + bytes(7)])
        finally:
            v.close()


if __name__ == "__main__":
    unittest.main(verbosity=2)
