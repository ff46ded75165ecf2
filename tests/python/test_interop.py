"""Interop: python-canopen (an independent CANopen master) drives `vnode` over SLCAN.

Runs with the venv `cargo xtask test` creates:
    .venv/bin/python -m unittest discover -s tests/python -v
The node is `vnode --device interop` (tests/eds/interop.eds) unless VNODE_DEVICE says otherwise.
"""

import os
import re
import subprocess
import threading
import time
import unittest

import canopen

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
VNODE = os.environ.get("VNODE", os.path.join(ROOT, "target", "debug", "vnode"))
EDS = os.path.join(ROOT, "tests", "eds", "interop.eds")
NODE_ID = 5


class Vnode:
    """One vnode process and a python-canopen network connected to it at `bitrate`; the node
    `node_id` with `eds` added to it unless `eds` is None."""

    def __init__(self, device="interop", node_id=NODE_ID, eds=EDS, extra=(), bitrate=500000):
        self.proc = subprocess.Popen(
            [VNODE, "--device", device, "--node-id", str(node_id), "--listen", "127.0.0.1:0", *extra],
            stdout=subprocess.PIPE,
            text=True,
        )
        line = self.proc.stdout.readline()
        port = int(re.search(r":(\d+)\s*$", line).group(1))
        self.port = port
        self.network = canopen.Network()
        # The notifier's receive timeout bounds disconnect(): python-canopen's 1 s default
        # added a second to every test's teardown.
        self.network.NOTIFIER_CYCLE = 0.05
        self.network.connect(interface="slcan", channel=f"socket://127.0.0.1:{port}", bitrate=bitrate, sleep_after_open=0)
        if eds is not None:
            self.node = self.network.add_node(node_id, eds)
            self.node.sdo.RESPONSE_TIMEOUT = 2.0

    def close(self):
        try:
            self.network.disconnect()
        finally:
            self.proc.terminate()
            self.proc.wait(timeout=5)
            self.proc.stdout.close()


class FreshNode(unittest.TestCase):
    """A test case with its own vnode (the interop node), reset to its power-on values."""

    def setUp(self):
        self.v = Vnode()
        # A cleanup also runs when setUp fails, so no vnode is left behind.
        self.addCleanup(self.v.close)
        self.node = self.v.node
        # Every test starts from the power-on values. Frames on one link stay in
        # order, so the SDO answer that follows proves the reset happened
        # (waiting for the boot-up frame could miss one sent before the wait began).
        self.node.nmt.send_command(0x81)
        self.node.sdo.upload(0x1000, 0)


class InteropTest(FreshNode):
    def reset_and_see_bootup(self, command):
        """Sends an NMT reset and waits for the boot-up frame, listening from before the send."""
        seen = threading.Event()

        def on_frame(can_id, data, timestamp):
            if bytes(data) == b"\x00":
                seen.set()

        self.v.network.subscribe(0x700 + NODE_ID, on_frame)
        try:
            self.node.nmt.send_command(command)
            self.assertTrue(seen.wait(2), "boot-up frame")
        finally:
            self.v.network.unsubscribe(0x700 + NODE_ID, on_frame)

    # ---- SDO ---------------------------------------------------------------

    def test_expedited_upload_and_download_of_1_to_4_bytes(self):
        cases = [(0x2000, b"\x11", b"\xA5"), (0x2001, b"\x22\x22", b"\x34\x12"), (0x2002, b"\x33\x33\x33", b"\x01\x02\x03"),
                 (0x2003, b"\x44\x44\x44\x44", b"\xEF\xBE\xAD\xDE")]
        for index, default, new in cases:
            self.assertEqual(self.node.sdo.upload(index, 0), default)
            self.node.sdo.download(index, 0, new)
            self.assertEqual(self.node.sdo.upload(index, 0), new)

    def test_segmented_upload_and_download_of_100_plus_bytes(self):
        text = self.node.sdo.upload(0x2005, 0)
        self.assertTrue(text.startswith(b"The quick brown fox"))
        self.assertGreater(len(text), 100)
        new = bytes(range(32, 32 + 110))
        self.node.sdo.download(0x2005, 0, new)
        self.assertEqual(self.node.sdo.upload(0x2005, 0), new)
        blob = bytes((i * 7) & 0xFF for i in range(200))
        self.node.sdo.download(0x2006, 0, blob)
        self.assertEqual(self.node.sdo.upload(0x2006, 0), blob)

    def test_block_upload_and_download_with_crc(self):
        blob = bytes((i * 13 + 1) & 0xFF for i in range(200))
        with self.node.sdo.open(0x2006, 0, "wb", size=len(blob), block_transfer=True) as f:
            f.write(blob)
        with self.node.sdo.open(0x2006, 0, "rb", block_transfer=True) as f:
            self.assertEqual(f.read(), blob)
        with self.node.sdo.open(0x2005, 0, "rb", block_transfer=True) as f:
            self.assertTrue(f.read().startswith(b"The quick brown fox"))

    def test_aborts_come_with_the_cia301_code(self):
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo.upload(0x3000, 0)
        self.assertEqual(e.exception.code, 0x06020000)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo.upload(0x2000, 1)
        self.assertEqual(e.exception.code, 0x06090011)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo.download(0x1000, 0, b"\0\0\0\0")
        self.assertEqual(e.exception.code, 0x06010002)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo.download(0x2004, 0, (2000000).to_bytes(4, "little"))
        self.assertEqual(e.exception.code, 0x06090031)

    def test_a_second_sdo_server_serves_a_second_client(self):
        # 0x1201 (CiA 301 §7.2.4.1): off by default, on once both COB-IDs are valid.
        self.assertEqual(self.node.sdo[0x1201][1].raw, 0x80000000)
        self.node.sdo[0x1201][1].raw = 0x6A5
        self.node.sdo[0x1201][2].raw = 0x6B5
        self.node.sdo[0x1201][3].raw = 0x10
        client = canopen.sdo.SdoClient(0x6A5, 0x6B5, self.node.object_dictionary)
        client.network = self.v.network
        self.v.network.subscribe(0x6B5, client.on_response)
        self.assertEqual(client.upload(0x1008, 0), b"canopen-rs interop node")
        client.download(0x2003, 0, b"\x01\x02\x03\x04")
        self.assertEqual(self.node.sdo.upload(0x2003, 0), b"\x01\x02\x03\x04")
        blob = bytes((i * 5 + 3) & 0xFF for i in range(200))
        client.download(0x2006, 0, blob)
        with client.open(0x2006, 0, "rb", block_transfer=True) as f:
            self.assertEqual(f.read(), blob)
        # A restricted CAN-ID (the default SDO range) is refused.
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo[0x1201][1].raw = 0x80000000
            self.node.sdo[0x1201][1].raw = 0x605
        self.assertEqual(e.exception.code, 0x06090030)

    # ---- NMT and heartbeat -------------------------------------------------

    def test_nmt_commands_and_heartbeat(self):
        self.node.sdo["Producer heartbeat time"].raw = 100
        self.assertEqual(self.node.nmt.wait_for_heartbeat(1), "PRE-OPERATIONAL")
        for state in ["OPERATIONAL", "STOPPED", "PRE-OPERATIONAL"]:
            self.node.nmt.state = state
            time.sleep(0.15)
            self.assertEqual(self.node.nmt.wait_for_heartbeat(1), state)
        self.reset_and_see_bootup(0x82)  # reset communication: 0x1017 back to 0
        with self.assertRaises(canopen.nmt.NmtError):
            self.node.nmt.wait_for_heartbeat(0.5)

    def test_wait_for_bootup_after_the_reset_command_sees_the_boot_up(self):
        # The plain python-canopen way: python-canopen listens for the boot-up
        # only once wait_for_bootup runs, so a node that answered within
        # 0.3 ms (vnode before its 20 ms restart time) was missed about one
        # reset in three.
        for command in [0x81, 0x82] * 5:
            self.node.nmt.send_command(command)
            self.node.nmt.wait_for_bootup(2)
            self.assertEqual(self.node.nmt.state, "PRE-OPERATIONAL")

    # ---- EMCY --------------------------------------------------------------

    def test_emcy_on_heartbeat_consumer_timeout(self):
        # Consume the heartbeat of node 0x10 with 100 ms; one heartbeat arms it.
        self.node.sdo[0x1016][1].raw = (0x10 << 16) | 100
        self.v.network.send_message(0x710, [0x05])
        emcy = self.node.emcy.wait(0x8130, timeout=2)
        self.assertIsNotNone(emcy)
        self.assertEqual(emcy.register & 0x11, 0x11)
        self.assertEqual(emcy.data[0], 0x10)
        self.assertEqual(self.node.sdo[0x1001].raw & 0x10, 0x10)
        # 0x1003 holds it, newest at sub 1; a sub-index above the count holds no error:
        # "no data available" (CiA 301 §7.5.2.4, as CANopenNode answers), not a 0.
        self.assertEqual(self.node.sdo[0x1003][0].raw, 1)
        self.assertEqual(self.node.sdo[0x1003][1].raw & 0xFFFF, 0x8130)
        with self.assertRaises(canopen.SdoAbortedError) as e:
            self.node.sdo[0x1003][2].raw
        self.assertEqual(e.exception.code, 0x08000024)

    # ---- PDO ---------------------------------------------------------------

    def test_pdo_remapping_through_the_pdo_api_and_saving_it(self):
        self.node.tpdo.read()
        tpdo = self.node.tpdo[1]
        tpdo.clear()
        tpdo.add_variable(0x2004)
        tpdo.add_variable(0x2007)
        tpdo.trans_type = 254
        tpdo.event_timer = 50
        tpdo.enabled = True
        self.node.tpdo.save()
        self.node.sdo[0x2004].raw = -1234
        self.node.sdo[0x2007].raw = 2.5
        self.node.nmt.state = "OPERATIONAL"
        tpdo.wait_for_reception(timeout=2)
        self.assertEqual(tpdo[0x2004].raw, -1234)
        self.assertEqual(tpdo[0x2007].raw, 2.5)
        # Saved with 0x1010 and still mapped after a reset node.
        self.node.store()
        self.reset_and_see_bootup(0x81)
        self.node.tpdo.read()
        self.assertEqual([v.index for v in self.node.tpdo[1].map], [0x2004, 0x2007])
        self.assertEqual(self.node.tpdo[1].event_timer, 50)

    def test_rpdo_writes_the_mapped_objects(self):
        self.node.rpdo.read()
        self.node.nmt.state = "OPERATIONAL"
        rpdo = self.node.rpdo[1]
        for i, value in enumerate([0x1111, 0x2222, 0x3333, 0x4444], start=1):
            rpdo[f"Setpoints.Setpoint {i}"].raw = value
        rpdo.transmit()
        time.sleep(0.1)
        self.assertEqual(self.node.sdo[0x2100][3].raw, 0x3333)


if __name__ == "__main__":
    unittest.main(verbosity=2)
