"""Interop: SDO transfers of every size class, python-canopen (the independent client) against `vnode`.

Expedited (1 to 4 bytes), segmented and block transfers at the segment boundaries (7/8, 14/15, …),
block uploads with block sizes from 1 to 127, aborts in the middle of a transfer and the server's
SDO timeout. Runs as test_interop.py does:
    .venv/bin/python -m unittest tests/python/test_sdo_sizes.py -v

The objects (tests/eds/interop.eds): 0x2006 is an OCTET_STRING of 200 bytes, which keeps its size
(a shorter download is padded with zeros); 0x2005 a VISIBLE_STRING of up to 123 characters, which
reads back as long as it was written (up to its first NUL).
"""

import threading
import time
import unittest

import canopen
from canopen.sdo import client as sdo_client

from test_interop import NODE_ID, FreshNode

OCTETS = 0x2006
OCTETS_LEN = 200
TEXT = 0x2005
TEXT_LEN = 123
RX = 0x600 + NODE_ID
TX = 0x580 + NODE_ID

# Every size class: expedited 1..=4, segmented from 5, the boundaries of one, two, three and four
# segments (7/8, 14/15, 21/22, 28/29), and the largest the object holds.
SIZES = list(range(1, 17)) + [20, 21, 22, 27, 28, 29, 100, OCTETS_LEN - 1, OCTETS_LEN]


def pattern(size, salt):
    return bytes((i * 7 + salt) & 0xFF for i in range(size))


class SdoSizesTest(FreshNode):
    def block_upload(self, index, blksize):
        """A block upload with the client asking for `blksize` segments per block."""
        saved = sdo_client.BlockUploadStream.blksize
        sdo_client.BlockUploadStream.blksize = blksize
        try:
            with self.node.sdo.open(index, 0, "rb", block_transfer=True) as f:
                return f.read()
        finally:
            sdo_client.BlockUploadStream.blksize = saved

    def block_download(self, index, data):
        with self.node.sdo.open(index, 0, "wb", size=len(data), block_transfer=True) as f:
            f.write(data)

    def raw(self):
        """Collects the server's frames; returns (send, frames, arrived)."""
        frames = []
        arrived = threading.Condition()

        def on_frame(can_id, data, timestamp):
            with arrived:
                frames.append(bytes(data))
                arrived.notify_all()

        self.v.network.subscribe(TX, on_frame)
        self.addCleanup(self.v.network.unsubscribe, TX, on_frame)

        def exchange(request, timeout=2.0):
            """Sends `request` and returns the server's next frame (None if none came)."""
            with arrived:
                seen = len(frames)
                self.v.network.send_message(RX, bytes(request))
                arrived.wait_for(lambda: len(frames) > seen, timeout)
                return frames[seen] if len(frames) > seen else None

        return exchange, frames, arrived

    # ---- sizes -------------------------------------------------------------

    def test_every_size_class_downloaded_and_uploaded_segmented_and_by_block(self):
        for size in SIZES:
            with self.subTest(size=size):
                data = pattern(size, size)
                padded = data + bytes(OCTETS_LEN - size)
                self.node.sdo.download(OCTETS, 0, data)
                self.assertEqual(self.node.sdo.upload(OCTETS, 0), padded)
                data = pattern(size, size + 1)
                padded = data + bytes(OCTETS_LEN - size)
                self.block_download(OCTETS, data)
                self.assertEqual(self.block_upload(OCTETS, 127), padded)

    def test_visible_string_reads_back_as_long_as_it_was_written(self):
        for size in [1, 4, 5, 6, 7, 8, 13, 14, 15, 21, 22, 100, TEXT_LEN - 1, TEXT_LEN]:
            with self.subTest(size=size):
                text = bytes(0x41 + (i % 26) for i in range(size))
                self.node.sdo.download(TEXT, 0, text)
                self.assertEqual(self.node.sdo.upload(TEXT, 0), text)
                self.assertEqual(self.block_upload(TEXT, 5), text)
                text = text.lower()
                self.block_download(TEXT, text)
                self.assertEqual(self.node.sdo.upload(TEXT, 0), text)

    def test_block_upload_with_every_block_size(self):
        # 200 bytes are 29 segments: block sizes below, at and above that, 1 and 127 included.
        data = pattern(OCTETS_LEN, 3)
        self.node.sdo.download(OCTETS, 0, data)
        for blksize in [1, 2, 3, 4, 7, 13, 14, 15, 28, 29, 30, 64, 126, 127]:
            with self.subTest(blksize=blksize):
                self.assertEqual(self.block_upload(OCTETS, blksize), data)

    def test_a_value_longer_than_the_object_is_refused_and_leaves_it_unchanged(self):
        data = pattern(OCTETS_LEN, 9)
        self.node.sdo.download(OCTETS, 0, data)
        for size in [OCTETS_LEN + 1, 255, 256, 889, 890]:
            with self.subTest(size=size):
                with self.assertRaises(canopen.SdoAbortedError) as e:
                    self.node.sdo.download(OCTETS, 0, bytes(size))
                self.assertEqual(e.exception.code, 0x06070012)
                with self.assertRaises(canopen.SdoAbortedError) as e:
                    self.block_download(OCTETS, bytes(size))
                self.assertEqual(e.exception.code, 0x06070012)
                self.assertEqual(self.node.sdo.upload(OCTETS, 0), data)

    def test_expedited_download_without_size_takes_the_entry_length(self):
        exchange, _, _ = self.raw()
        # e = 1, s = 0 with 4 data bytes to an UNSIGNED16: the first two are the value.
        self.assertEqual(exchange([0x22, 0x01, 0x20, 0x00, 0x34, 0x12, 0x56, 0x78]),
                         bytes([0x60, 0x01, 0x20, 0x00, 0, 0, 0, 0]))
        self.assertEqual(self.node.sdo.upload(0x2001, 0), b"\x34\x12")
        # To a read-only object: 0x06010002 whatever the size.
        self.assertEqual(exchange([0x22, 0x00, 0x10, 0x00, 1, 2, 3, 4]),
                         bytes([0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06]))

    # ---- aborts and timeouts -----------------------------------------------

    def test_client_abort_in_the_middle_of_a_segmented_download_keeps_the_old_value(self):
        old = pattern(OCTETS_LEN, 5)
        self.node.sdo.download(OCTETS, 0, old)
        exchange, _, _ = self.raw()
        self.assertEqual(exchange([0x21, 0x06, 0x20, 0x00, 20, 0, 0, 0]), bytes([0x60, 0x06, 0x20, 0x00, 0, 0, 0, 0]))
        self.assertEqual(exchange([0x00, 1, 2, 3, 4, 5, 6, 7]), bytes([0x20, 0, 0, 0, 0, 0, 0, 0]))
        # The abort ends the transfer without an answer; the next request is served as from idle.
        self.v.network.send_message(RX, bytes([0x80, 0x06, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05]))
        self.assertEqual(self.node.sdo.upload(OCTETS, 0), old)
        # A segment now belongs to no transfer.
        self.assertEqual(exchange([0x10, 8, 9, 10, 11, 12, 13, 14]), bytes([0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05]))

    def test_client_abort_in_the_middle_of_a_segmented_upload_then_a_new_one(self):
        data = pattern(OCTETS_LEN, 6)
        self.node.sdo.download(OCTETS, 0, data)
        exchange, _, _ = self.raw()
        self.assertEqual(exchange([0x40, 0x06, 0x20, 0x00, 0, 0, 0, 0]), bytes([0x41, 0x06, 0x20, 0x00, OCTETS_LEN, 0, 0, 0]))
        self.assertEqual(exchange([0x60, 0, 0, 0, 0, 0, 0, 0]), bytes([0x00]) + data[:7])
        self.v.network.send_message(RX, bytes([0x80, 0x06, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05]))
        self.assertEqual(self.node.sdo.upload(OCTETS, 0), data)
        self.assertEqual(self.block_upload(OCTETS, 7), data)

    def test_client_abort_in_the_middle_of_a_block_download_keeps_the_old_value(self):
        old = pattern(OCTETS_LEN, 7)
        self.node.sdo.download(OCTETS, 0, old)
        exchange, _, _ = self.raw()
        # Block download initiate with CRC and size 50; the server names its block size.
        answer = exchange([0xC6, 0x06, 0x20, 0x00, 50, 0, 0, 0])
        self.assertEqual(answer[:4], bytes([0xA4, 0x06, 0x20, 0x00]))
        self.assertTrue(1 <= answer[4] <= 127, answer.hex())
        for seq in (1, 2, 3):
            self.v.network.send_message(RX, bytes([seq]) + bytes(7))
        self.v.network.send_message(RX, bytes([0x80, 0x06, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05]))
        self.assertEqual(self.node.sdo.upload(OCTETS, 0), old)
        data = pattern(50, 8)
        self.block_download(OCTETS, data)
        self.assertEqual(self.node.sdo.upload(OCTETS, 0), data + bytes(OCTETS_LEN - 50))

    def test_a_stalled_segmented_download_times_out_with_0x05040000(self):
        exchange, frames, arrived = self.raw()
        start = time.monotonic()
        self.assertEqual(exchange([0x21, 0x06, 0x20, 0x00, 20, 0, 0, 0]), bytes([0x60, 0x06, 0x20, 0x00, 0, 0, 0, 0]))
        with arrived:
            self.assertTrue(arrived.wait_for(lambda: len(frames) >= 2, 3.0), "timeout abort")
        elapsed = time.monotonic() - start
        self.assertEqual(frames[1], bytes([0x80, 0x06, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05]))
        self.assertGreaterEqual(elapsed, 0.9)
        # The transfer is over: its next segment is refused, a new transfer is served.
        self.assertEqual(exchange([0x00, 1, 2, 3, 4, 5, 6, 7]), bytes([0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05]))
        self.assertEqual(self.node.sdo.upload(0x2000, 0), b"\x11")

    def test_a_stalled_block_upload_times_out_with_0x05040000(self):
        exchange, frames, arrived = self.raw()
        # Block upload initiate, blksize 10, no start request: the server waits for it.
        answer = exchange([0xA4, 0x06, 0x20, 0x00, 10, 0, 0, 0])
        self.assertEqual(answer, bytes([0xC6, 0x06, 0x20, 0x00, OCTETS_LEN, 0, 0, 0]))
        with arrived:
            self.assertTrue(arrived.wait_for(lambda: len(frames) >= 2, 3.0), "timeout abort")
        self.assertEqual(frames[1], bytes([0x80, 0x06, 0x20, 0x00, 0x00, 0x00, 0x04, 0x05]))
        self.assertEqual(self.block_upload(OCTETS, 10), bytes(OCTETS_LEN))


if __name__ == "__main__":
    unittest.main()
