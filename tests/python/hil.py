"""Bench check of a board: the QEMU smoke checks against a real node through
any adapter python-can supports, including a save across a power cycle.

    cargo xtask hil --interface slcan --channel /dev/ttyACM0 --bitrate 250000 --device ec5000 --node-id 127
    cargo xtask hil --interface socketcan --channel can0 --device sendix --node-id 63
    cargo xtask hil --qemu --device ec5000 --node-id 127      # the QEMU image (what CI runs)

Checks, each printed as PASS/FAIL (exit code 1 if one fails): boot-up (NMT
reset node if none came within a few seconds), identity (0x1000, 0x1018
against the EDS), an SDO abort, NMT start/stop/pre-operational seen in the
heartbeat (or node guarding), TPDO1 by event timer against SDO reads, RPDO1
read back by SDO, no EMCY, and 0x1017 saved with 0x1010 across a power
cycle. The power cycle runs `--power-cycle-command` if given, else the
script waits for the user to cycle the power and press Enter. With `--qemu
ELF` the script runs the image itself, in a directory holding its storage
file (docs/firmware.md, "QEMU storage across restarts"), and a power cycle
kills QEMU and starts it again. At the end 0x1011 "load" restores the
defaults for the next power-on, so the board is left as found.
"""

import argparse
import logging
import os
import shlex
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
import time

import can
import canopen

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_qemu_smoke import EXIT_ID, NO_OBJECT, OPERATIONAL, SIGNED, FrameLog, free_port  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STORAGE_FILE = "canopen-qemu-storage.bin"  # firmware/src/boards/qemu/host_file.rs
STOPPED, PRE_OPERATIONAL = 0x04, 0x7F
WAIT = 5.0


class BusLog(FrameLog):
    """The frame log, and the end of python-can's receive thread when the link
    drops (QEMU exited, an adapter unplugged) as one line on stderr instead of
    the thread's traceback: the checks that follow fail as FAIL lines."""

    def __init__(self):
        super().__init__()
        self.ended = None

    def on_error(self, exc):
        if self.ended is None:
            self.ended = exc
            cause = f" ({exc.__cause__})" if exc.__cause__ else ""
            print(f"hil.py: the connection to the bus ended: {exc}{cause}", file=sys.stderr, flush=True)


class SameEndOnce(logging.Filter):
    """python-canopen logs the receive thread's end again at each send: BusLog said it."""

    def filter(self, record):
        return record.getMessage() != "An error has caused receiving of messages to stop"


logging.getLogger("canopen.network").addFilter(SameEndOnce())


class Qemu:
    """A QEMU image whose storage file survives its restarts."""

    def __init__(self, elf):
        self.elf = os.path.abspath(elf)
        self.dir = tempfile.mkdtemp(prefix="canopen-hil-")
        open(os.path.join(self.dir, STORAGE_FILE), "wb").close()  # empty: the firmware erases it
        self.proc = None

    def start(self):
        self.port = free_port()
        self.log = open(os.path.join(self.dir, "defmt.log"), "ab")
        self.proc = subprocess.Popen(
            ["qemu-system-arm", "-M", "lm3s6965evb", "-cpu", "cortex-m3", "-display", "none", "-monitor", "none",
             "-semihosting-config", "enable=on,target=native", "-icount", "shift=4,align=off,sleep=on",
             "-serial", f"tcp:127.0.0.1:{self.port},server=on,wait=on,nodelay=on", "-kernel", self.elf],
            cwd=self.dir, stdout=self.log, stderr=subprocess.PIPE, text=True)
        listening = threading.Event()
        self.stderr = []

        def read():
            for line in self.proc.stderr:
                self.stderr.append(line)
                if "waiting for connection" in line:
                    listening.set()
        threading.Thread(target=read, daemon=True).start()
        end = time.monotonic() + WAIT
        while not listening.wait(0.05):
            # A QEMU that ends at once (no such image, a bad one) says why on stderr.
            if self.proc.poll() is not None or time.monotonic() > end:
                time.sleep(0.1)
                why = "".join(self.stderr).strip() or f"exit status {self.proc.poll()}"
                raise RuntimeError(f"QEMU did not open its serial port: {why}")
        return f"socket://127.0.0.1:{self.port}"

    def remove(self):
        """Deletes the directory with the storage file and the defmt log."""
        shutil.rmtree(self.dir, ignore_errors=True)

    def power_cut(self):
        if self.proc and self.proc.poll() is None:
            self.proc.kill()
        if self.proc:
            self.proc.wait()
            self.log.close()

    def exit_code(self):
        try:
            return self.proc.wait(WAIT)
        except subprocess.TimeoutExpired:
            return None


class Bench:
    def __init__(self, args):
        self.args = args
        self.qemu = Qemu(args.qemu) if args.qemu else None
        self.od = canopen.import_od(args.eds or os.path.join(ROOT, "firmware", "eds", f"{args.device}.eds"), args.node_id)
        self.failed = 0
        self.network = None

    def check(self, ok, what):
        print(f"{'PASS' if ok else 'FAIL'}  {what}", flush=True)
        if not ok:
            self.failed += 1
        return ok

    # ---- the bus ---------------------------------------------------------------
    def connect(self):
        channel, interface = self.args.channel, self.args.interface
        if self.qemu:
            channel, interface = self.qemu.start(), "slcan"
        # A serial SLCAN adapter may need its default pause after opening; a TCP one does not.
        kwargs = {"sleep_after_open": 0} if interface == "slcan" and str(channel).startswith("socket://") else {}
        bus = can.Bus(interface=interface, channel=channel, bitrate=self.args.bitrate, **kwargs)
        self.frames = BusLog()
        self.network = canopen.Network(bus)
        self.network.listeners.append(self.frames)
        self.network.connect()
        self.node = canopen.RemoteNode(self.args.node_id, self.od)
        self.network.add_node(self.node)
        self.node.sdo.RESPONSE_TIMEOUT = 2.0

    def disconnect(self):
        if self.network is None:
            return
        bus = self.network.bus
        sock = getattr(getattr(bus, "serialPortOrig", None), "_socket", None)
        try:
            self.network.disconnect()
        except (can.CanError, OSError):
            pass  # the adapter (or QEMU) went away first
        if sock is not None:
            sock.close()
        self.network = None

    def error_control(self):
        return 0x700 + self.args.node_id

    def boot_up_seen(self, mark, timeout):
        boot = lambda m: m.arbitration_id == self.error_control() and bytes(m.data) == b"\x00"  # noqa: E731
        return self.frames.wait_for(boot, after=mark, timeout=timeout) is not None

    def wait_boot_up(self, mark=0, timeout=3.0):
        boot = lambda m: m.arbitration_id == self.error_control() and bytes(m.data) == b"\x00"  # noqa: E731
        if self.frames.wait_for(boot, after=mark, timeout=timeout):
            return True
        # It booted before we listened: reset it.
        print("      no boot-up seen: NMT reset node")
        mark = self.frames.mark()
        self.node.nmt.send_command(0x81)
        return self.frames.wait_for(boot, after=mark, timeout=WAIT) is not None

    def u(self, index, sub=0):
        return int.from_bytes(self.node.sdo.upload(index, sub), "little")

    def state_seen(self, state):
        """The node's NMT state in its next heartbeat (or guarding answer)."""
        mark = self.frames.mark()
        if 0x1017 not in self.od:
            self.network.send_message(self.error_control(), b"", remote=True)
        # A heartbeat already on its way when the command left still shows
        # the old state: the new one must appear within the wait.
        frame = self.frames.wait_for(
            lambda m: m.arbitration_id == self.error_control() and len(m.data) == 1 and m.data[0] & 0x7F == state, after=mark
        )
        return frame is not None

    def power_cycle(self):
        """Cuts and restores the node's power; whether its boot-up followed
        (None: no one cycled it)."""
        if self.qemu:
            # The TCP link goes with QEMU; the new QEMU waits for it before it runs.
            self.disconnect()
            self.qemu.power_cut()
            self.connect()
            return self.boot_up_seen(0, WAIT)
        # A real adapter stays connected, so the boot-up is seen.
        mark = self.frames.mark()
        if self.args.power_cycle_command:
            subprocess.run(self.args.power_cycle_command, shell=True, check=True)
        else:
            try:
                input("Cycle the board's power now (off, wait a second, on), then press Enter... ")
            except EOFError:
                # No one to press Enter (stdin closed, a CI job): say how to automate it.
                print("\n      no input to wait for: give --power-cycle-command to cycle the power")
                return None
        return self.boot_up_seen(mark, 10.0)

    # ---- the checks ------------------------------------------------------------
    def run(self):
        od, node = self.od, None
        self.connect()
        node = self.node
        if not self.check(self.wait_boot_up(timeout=WAIT if self.qemu else 3.0), f"boot-up 0x{self.error_control():03X} [00]"):
            # Not even after NMT reset node: every other check would only time out.
            print(f"stopped: node {self.args.node_id} sent no boot-up, not even after NMT reset node "
                  "(check the node-id, the bit rate, the wiring and the termination)")
            return 1
        self.check(self.u(0x1000) == od[0x1000].default, f"0x1000 device type = 0x{od[0x1000].default:08X}")
        identity = od[0x1018]
        for sub in range(1, identity[0].default + 1):
            if sub in identity and sub != 4:  # the serial number is the board's own
                self.check(self.u(0x1018, sub) == identity[sub].default, f"0x1018 sub {sub} = 0x{identity[sub].default:08X}")
        missing = next(i for i in (0x1FFF, 0x2FFF, 0x5FFF, 0x9FFF) if i not in od)
        try:
            node.sdo.upload(missing, 0)
            self.check(False, f"SDO upload of 0x{missing:04X} aborts")
        except canopen.SdoAbortedError as e:
            self.check(e.code == NO_OBJECT, f"SDO upload of 0x{missing:04X} aborts 0x{NO_OBJECT:08X} (got 0x{e.code:08X})")

        if 0x1017 in od:
            node.sdo.download(0x1017, 0, struct.pack("<H", 100))
        node.nmt.send_command(0x01)
        self.check(self.state_seen(OPERATIONAL), "NMT start: Operational in the heartbeat")
        if 0x1800 in od:
            self.check_tpdo()
        if 0x1400 in od:
            self.check_rpdo()
        node.nmt.send_command(0x02)
        self.check(self.state_seen(STOPPED), "NMT stop: Stopped")
        node.nmt.send_command(0x80)
        self.check(self.state_seen(PRE_OPERATIONAL), "NMT pre-operational: Pre-operational")
        emcy = self.frames.since(0, 0x80 + self.args.node_id)
        self.check(emcy == [], f"no EMCY ({[bytes(m.data).hex() for m in emcy]})")
        self.check(self.u(0x1001) == 0, "0x1001 error register = 0")

        if 0x1010 in od and 0x1017 in od:
            node.sdo.download(0x1017, 0, struct.pack("<H", 150))
            # Sub 1 "all", or sub 2 "communication" where sub 1 reads 0 ("does not save on
            # command": the b maXX 4400, D10); in Pre-operational, where every device stores.
            sub = 1 if self.u(0x1010, 1) & 1 else 2
            node.sdo.download(0x1010, sub, b"save")
            cycled = self.power_cycle()
            self.check(bool(cycled), "boot-up after the power cycle")
            if cycled is None:
                print("SKIP  0x1017 after the power cycle (there was none)")
            else:
                self.check(self.u(0x1017) == 150, "0x1017 = 150 ms saved with 0x1010 came back after the power cycle")
            # Leave the board as found: defaults from the next power-on.
            node = self.node
            node.sdo.download(0x1011, sub, b"load")
        else:
            print("SKIP  save across a power cycle (no 0x1010 or 0x1017)")

        if self.qemu:
            self.network.notifier.stop()
            self.network.send_message(EXIT_ID, b"EXIT\x00")
            self.check(self.qemu.exit_code() == 0, "QEMU exit code 0")
        self.disconnect()
        if self.qemu:
            self.qemu.power_cut()
        print(f"{'all checks passed' if not self.failed else f'{self.failed} check(s) failed'}")
        return 1 if self.failed else 0

    def mapping(self, index):
        count = self.u(index, 0)
        entries = [self.u(index, s) for s in range(1, count + 1)]
        return [(e >> 16, (e >> 8) & 0xFF, e & 0xFF) for e in entries]

    def check_tpdo(self):
        cob_id = self.u(0x1800, 1)
        if cob_id & 0x80000000:
            print("SKIP  TPDO1 (disabled)")
            return
        self.node.sdo.download(0x1800, 5, struct.pack("<H", 50))
        mapped = self.mapping(0x1A00)
        read = lambda: [self.node.sdo.upload(i, s)[: bits // 8] for i, s, bits in mapped]  # noqa: E731
        before = read()
        mark = self.frames.mark()
        pdo = self.frames.wait_for(lambda m: m.arbitration_id == cob_id & 0x7FF, after=mark)
        after = read()
        # A value that moves on its own (an encoder's position) is checked
        # for its place and size only; every other one byte for byte.
        ok, at = pdo is not None and len(pdo.data) == len(b"".join(after)), 0
        for first, last in zip(before, after):
            if ok and first == last:
                ok = bytes(pdo.data[at : at + len(last)]) == last
            at += len(last)
        self.check(ok, f"TPDO1 0x{cob_id & 0x7FF:03X} carries its mapped objects")
        self.node.sdo.download(0x1800, 5, struct.pack("<H", 0))

    def check_rpdo(self):
        cob_id = self.u(0x1400, 1)
        if cob_id & 0x80000000:
            print("SKIP  RPDO1 (disabled)")
            return
        payload, expected = b"", []
        for index, sub, bits in self.mapping(0x1600):
            var = self.od.get_variable(index, sub)
            signed = var.data_type in SIGNED
            current = int.from_bytes(self.node.sdo.upload(index, sub), "little", signed=signed)
            top = var.max if var.max is not None else (1 << (bits - signed)) - 1
            value = current + 1 if current < top else current - 1
            raw = (value & ((1 << bits) - 1)).to_bytes(bits // 8, "little")
            payload += raw
            expected.append((index, sub, raw))
        self.network.send_message(cob_id & 0x7FF, payload)
        got = [self.node.sdo.upload(i, s) for i, s, _ in expected]
        self.check(got == [raw for _, _, raw in expected], f"RPDO1 0x{cob_id & 0x7FF:03X} written, read back by SDO")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--interface", default="slcan", help="python-can interface (slcan, socketcan, pcan, kvaser, ...)")
    p.add_argument("--channel", help="python-can channel (/dev/ttyACM0, can0, PCAN_USBBUS1, socket://HOST:PORT, ...)")
    p.add_argument("--bitrate", type=int, default=250000)
    p.add_argument("--device", required=True, help="ec5000, unitek-ds, sendix, bmaxx4400 or agile")
    p.add_argument("--node-id", type=int, required=True)
    p.add_argument("--eds", help="the device's EDS (default firmware/eds/DEVICE.eds)")
    p.add_argument("--power-cycle-command", help="a shell command that cycles the board's power (default: ask the user)")
    p.add_argument("--qemu", metavar="ELF", help="run this QEMU image instead of talking to a board")
    args = p.parse_args()
    if not args.qemu and not args.channel:
        p.error("--channel is needed for a board")
    bench = Bench(args)
    try:
        return bench.run()
    except (canopen.SdoCommunicationError, can.CanError) as e:
        # The node stopped answering halfway (power, cable, a reset): a finding, not a crash.
        print(f"FAIL  the node stopped answering: {e}")
        print(f"{bench.failed + 1} check(s) failed")
        return 1
    except RuntimeError as e:
        print(f"FAIL  {e}")
        return 1
    finally:
        bench.disconnect()
        if bench.qemu:
            bench.qemu.power_cut()
            bench.qemu.remove()


if __name__ == "__main__":
    sys.exit(main())
