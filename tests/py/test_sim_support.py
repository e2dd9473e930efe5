"""Helpers shared by the octo-sim test files (this module holds no tests).

`SimUnderTest` starts build/octo-sim through conftest's `launch` on free ports
with a `Link` (xplane_proto) as the Data Output target, and offers the few
client actions the tests need (select rows, command throttles, step lockstep).
"""

import json
import re
import struct
import time

import xplane_proto as xp
from conftest import wait_until

HOVER = 2.132 * 9.796 / (8 * 28.0269)   # the paper's hover throttle, ~0.093
KF, KTAU = 28.0269, 0.3869
RATE = 90.0


class SimUnderTest:
    def __init__(self, launch, port, *args, rows=None):
        self.xp_port = port()
        self.link = xp.Link(self.xp_port, port=port())
        argv = ["--xp-port", self.xp_port, "--data-out", f"127.0.0.1:{self.link.port}", *args]
        if rows:
            argv += ["--rows", ",".join(str(r) for r in rows)]
        self.proc = launch("octo-sim", *argv)
        ok = wait_until(lambda: "Data Output to" in self.proc.stderr() or not self.proc.alive(), timeout=10)
        assert ok and self.proc.alive(), self.proc.stderr()

    # ---- client actions
    def send(self, dgram):
        self.link.send(dgram)

    def select(self, *rows):
        self.send(xp.encode_dsel(rows))

    def command(self, throttles):
        """All 8 throttles in one DATA row 25 record."""
        self.send(xp.encode_data({25: list(throttles)}))

    def next_data(self, timeout=2.0):
        """Next DATA datagram as {row: cols} (asserts that one arrives)."""
        d = self.link.recv_data(timeout)
        assert d is not None, "no DATA from octo-sim\n" + self.proc.stderr()
        return d

    def step(self, throttles, timeout=2.0):
        """Lockstep: command the 8 throttles, return the frame that follows."""
        self.command(throttles)
        return self.next_data(timeout)

    def start_lockstep(self, throttles):
        """Wait for the repeated frame 0, command, return frame 1."""
        f0 = self.next_data()
        assert f0[1][2] == 0.0 if 1 in f0 else True
        self.link.drain()
        f = self.step(throttles)
        # frames of the pre-start repetition may still be in flight: skip t = 0
        while 1 in f and f[1][2] == 0.0:
            f = self.next_data()
        return f

    def stop(self):
        rc = self.proc.stop()
        self.link.close()
        return rc

    def counters(self):
        """Stops octo-sim and returns its exit counters."""
        rc = self.stop()
        err = self.proc.stderr_path.read_text(errors="replace")
        assert rc == 0, err
        m = re.search(r"counters (\{.*\})", err)
        assert m, err
        return json.loads(m.group(1))


def mission_time(frame):
    return frame[1][2]


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]
