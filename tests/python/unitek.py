"""A UNITEK DS register-protocol session for python-can, shared by the vnode
test (test_unitek_vnode.py) and the QEMU smoke test: the drive is no CANopen
node (no boot-up, NMT or SDO), it answers READ 0x3D on its TX id 0x181, a
speed set-point moves the axis, and a cyclic read every 10 ms keeps its
period in the drive's own time (the position advances by exactly 10 ms of
motion per frame) and, loosely, in wall time. docs/devices/unitek-ds.md.
"""

import time

RX, TX = 0x201, 0x181
WAIT = 5.0
# 10 % speed (Ex. 3): 3277 Num of Nmax 3600 rpm = 393253 increments/s (65536 per revolution).
SPEED_10_PERCENT = b"\x31\xCD\x0C"
INC_PER_MS = 3277 * 3600 * 65536 / 60 / 32767 / 1000
CYCLES = 20


def session(t, send, frames, wall_period, strict):
    """Runs the session on `send(cob_id, data)`, reading replies from
    `frames` (mark/wait_for/since); `wall_period` = (lowest, highest) mean
    interval in seconds the cyclic frames may arrive at in wall time; `strict`:
    every period, not only their mean, is 10 ms in the drive's time."""

    def reply(mark, regid):
        m = frames.wait_for(lambda m: m.arbitration_id == TX and m.data[0] == regid, after=mark, timeout=WAIT)
        t.assertIsNotNone(m, f"no reply for register 0x{regid:02X}")
        return m

    def read(regid):
        mark = frames.mark()
        send(RX, bytes([0x3D, regid, 0x00]))
        return bytes(reply(mark, regid).data)

    def position():
        return int.from_bytes(read(0x6D)[1:5], "little", signed=True)

    # ---- not a CANopen node: NMT and SDO get nothing --------------------
    mark = frames.mark()
    send(0x000, b"\x01\x00")
    send(0x601, b"\x40\x00\x10\x00\x00\x00\x00\x00")
    # Frames on one link stay in order: the READ answer comes after anything those caused.
    t.assertEqual(read(0x1B), b"\x1B\xD8\x01\x00", "firmware 472, DLC 4")
    t.assertEqual([(hex(m.arbitration_id), bytes(m.data).hex()) for m in frames.frames[mark:] if m.arbitration_id != TX], [],
                  "no answer to NMT or SDO")

    # ---- Ex. 11: ready, RUN, enable, 10 % speed ---------------------------
    t.assertEqual(read(0xE2), b"\xE2\x01\x00\x00", "BTB")
    t.assertEqual(read(0xE8), b"\xE8\x01\x00\x00", "RUN")
    send(RX, b"\x51\x00\x00")
    send(RX, SPEED_10_PERCENT)
    t.assertEqual(read(0x40)[1] & 0x01, 0x01, "Ena")
    before = position()
    # The ramp takes 10 ms of the drive's time, which QEMU may stretch in wall time.
    deadline = time.monotonic() + WAIT
    while read(0x30) != b"\x30\xCD\x0C\x00" and time.monotonic() < deadline:
        time.sleep(0.01)
    t.assertEqual(read(0x30), b"\x30\xCD\x0C\x00", "SPEED_ACTUAL = 10 %")
    t.assertGreater(position() - before, 0, "the speed set-point moves the axis")

    # ---- cyclic read of POS_ACTUAL every 10 ms ---------------------------
    mark = frames.mark()
    send(RX, b"\x3D\x6D\x0A")
    deadline = time.monotonic() + WAIT * 4
    while len([m for m in frames.since(mark, TX) if m.data[0] == 0x6D]) < CYCLES + 1 and time.monotonic() < deadline:
        time.sleep(0.01)
    stop = frames.mark()
    send(RX, b"\x3D\x6D\xFF")
    send(RX, b"\x3D\x1B\x00")
    sync = reply(stop, 0x1B)
    cyclic = [m for m in frames.frames[mark:stop] if m.arbitration_id == TX and m.data[0] == 0x6D]
    t.assertGreaterEqual(len(cyclic), CYCLES + 1, "cyclic frames")
    t.assertTrue(all(len(m.data) == 6 for m in cyclic), "POS_ACTUAL is 32 bits: DLC 6")
    positions = [int.from_bytes(bytes(m.data[1:5]), "little", signed=True) for m in cyclic]
    steps = [b - a for a, b in zip(positions, positions[1:])]
    # The drive's time: the position advances by 10 ms of motion per period.
    # Under QEMU's instruction-counted clock every period is exact (a tick of
    # rounding at most) and so is their mean. vnode runs on the host's clock,
    # whose wake-ups a loaded host delays by milliseconds (a frame more than a
    # period late restarts the schedule from then): there the typical period,
    # the median, must be 10 ms.
    in_ms = sorted(s / INC_PER_MS for s in steps)
    if strict:
        t.assertAlmostEqual((positions[-1] - positions[0]) / INC_PER_MS / len(steps), 10.0, delta=0.11,
                            msg=f"mean period in drive time, steps {steps}")
        for step in in_ms:
            t.assertAlmostEqual(step, 10.0, delta=1.01, msg=f"period in drive time, steps {steps}")
    else:
        t.assertAlmostEqual(in_ms[len(in_ms) // 2], 10.0, delta=1.5, msg=f"median period in drive time, steps {steps}")
    # Wall time, loosely.
    wall = (cyclic[-1].timestamp - cyclic[0].timestamp) / (len(cyclic) - 1)
    t.assertGreaterEqual(wall, wall_period[0], f"mean wall period {wall * 1000:.2f} ms")
    t.assertLessEqual(wall, wall_period[1], f"mean wall period {wall * 1000:.2f} ms")
    # After the stop (and the READ behind it) no more cyclic frames.
    time.sleep(0.1)
    after = frames.frames.index(sync)
    t.assertEqual([m for m in frames.frames[after:] if m.arbitration_id == TX and m.data[0] == 0x6D], [], "stopped")

    # ---- stop and disable ------------------------------------------------
    send(RX, b"\x31\x00\x00")
    send(RX, b"\x51\x04\x00")
    t.assertEqual(read(0x40)[1] & 0x01, 0x00, "disabled")
    t.assertEqual(read(0x51), b"\x51\x04\x00\x00", "MODE")
    return 2  # NMT and SDO frames, which a board's acceptance filter drops
