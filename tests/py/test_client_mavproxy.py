"""octo-fw seen by MAVProxy (pinned, headless, driven through its command line on
stdin as a user types): parameter fetch (its FTP attempt NAKed, then the PARAM_*
protocol), set, save, arm, take-off, a status line longer than one STATUSTEXT, land; its mode display does not use
ArduCopter's names and it reports no fence breach. Every wait has a deadline."""

import os
import queue
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from test_fw_rig import Rig

MAVPROXY = Path(sys.executable).parent / "mavproxy.py"
ARDUCOPTER_NAMES = ("STABILIZE", "ACRO", "ALT_HOLD", "AUTO", "GUIDED", "LOITER", "RTL", "CIRCLE")


class MavProxy:
    """mavproxy.py with its console on pipes; expect() waits for a line pattern."""

    def __init__(self, master, logdir):
        if not MAVPROXY.exists():
            pytest.skip("mavproxy.py is not installed in the venv (make installs it)")
        self.lines, self.q = [], queue.Queue()
        self.p = subprocess.Popen(
            [sys.executable, str(MAVPROXY), f"--master={master}", "--dialect=octo", "--no-state",
             "--default-modules=param,misc,arm,cmdlong,fence", f"--state-basedir={logdir}",
             "--cmd=set requireexit True"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            cwd=logdir, start_new_session=True, env={**os.environ, "MAVLINK20": "1"})
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.p.stdout:
            self.q.put(line.rstrip("\n"))

    def send(self, cmd):
        self.p.stdin.write(cmd + "\n")
        self.p.stdin.flush()

    def expect(self, pattern, timeout):
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                line = self.q.get(timeout=0.1)
            except queue.Empty:
                continue
            self.lines.append(line)
            if rx.search(line):
                return line
        pytest.fail(f"MAVProxy printed no line matching {pattern!r} within {timeout} s; "
                    f"its output:\n" + "\n".join(self.lines[-60:]))

    def close(self):
        if self.p.poll() is None:
            try:
                self.send("exit")
                self.p.wait(timeout=5)
            except (BrokenPipeError, subprocess.TimeoutExpired):
                self.p.kill()
                self.p.wait(timeout=5)
        while not self.q.empty():
            self.lines.append(self.q.get())


@pytest.fixture
def mavproxy(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    rig.start_sim("--computer-name", "octo-mavproxy-test", lockstep=False)
    rig.start_fw()
    mp = MavProxy(f"udpin:127.0.0.1:{rig.gcs_port}", tmp_path)
    yield rig, mp
    mp.close()


def test_mavproxy_parameters_arm_takeoff_land(mavproxy, tmp_path):
    rig, mp = mavproxy
    mp.expect(r"Detected vehicle 1:1", 15)
    mp.expect(r"Received (\d+) parameters", 30)
    mp.send("param set NAV_TKO_ALT 4")
    for _ in range(10):      # the write is confirmed by the vehicle's PARAM_VALUE
        mp.send("param show NAV_TKO_ALT")
        if "4.0" in mp.expect(r"NAV_TKO_ALT\s+\d", 5):
            break
        time.sleep(0.5)
    else:
        pytest.fail("MAVProxy never showed NAV_TKO_ALT 4.0")
    saved = tmp_path / "saved.parm"
    mp.send(f"param save {saved}")
    mp.expect(r"Saved \d+ parameters", 10)
    assert re.search(r"^NAV_TKO_ALT\s+4\.0+\s*$", saved.read_text(), re.M)

    mp.send("arm throttle")
    mp.expect(r"COMPONENT_ARM_DISARM: ACCEPTED", 10)
    mp.send("takeoff 3")
    mp.expect(r"NAV_TAKEOFF: ACCEPTED", 10)
    mp.expect(r"Mode HOLD", 30)
    # a status line longer than STATUSTEXT's 50 characters reaches MAVProxy whole (its chunks joined)
    mp.send("param set ID_EXC_AMP 0")
    for _ in range(10):      # confirmed by the vehicle's PARAM_VALUE before the command
        mp.send("param show ID_EXC_AMP")
        if re.search(r"ID_EXC_AMP\s+0\.0+\b", mp.expect(r"ID_EXC_AMP\s+\d", 5)):
            break
        time.sleep(0.5)
    else:
        pytest.fail("MAVProxy never showed ID_EXC_AMP 0")
    for _ in range(10):
        mp.send("long USER_1 1")
        line = mp.expect(r"Experiment 1 refused: ", 5)
        if "not hovering" not in line:
            break
        time.sleep(1.0)
    assert re.search(r"AP: Experiment 1 refused: ID_EXC_AMP/ID_EXC_TIME not > 0$", line), line
    mp.send("long NAV_LAND")
    mp.expect(r"NAV_LAND: ACCEPTED", 10)
    mp.expect(r"Mode DISARMED", 40)
    mp.expect(r"^DISARMED", 10)
    mp.close()
    out = "\n".join(mp.lines)
    assert "fence breach" not in out
    for name in ARDUCOPTER_NAMES:
        assert not re.search(rf"\b{name}\b", out), f"MAVProxy shows ArduCopter's {name}:\n{out}"
