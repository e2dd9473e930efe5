"""octo-fw test rig (helpers, no tests): octo-sim and octo-fw on free ports, a
pymavlink ground station, and readers for both LCM logs.

    rig = Rig(launch, port, tmp_path, version=12, actuation="dref")
    rig.start(sim_args=["--duration", "60"])
    rig.cmd(MAV_CMD_COMPONENT_ARM_DISARM, 1)      -> (result, [statustexts])
"""

import math
import os
import sys
import time

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from conftest import BUILD, wait_until  # noqa: E402

sys.path.insert(0, str(BUILD / "gen" / "python"))

mavlink = mavutil.mavlink


class Rig:
    def __init__(self, launch, port, tmp_path, version=12, actuation="dref"):
        self.launch, self.port, self.tmp = launch, port, tmp_path
        self.version, self.actuation = version, actuation
        self.xp_port, self.xp_listen = port(), port()
        self.mav_port, self.gcs_port = port(), port()
        self.params = tmp_path / "params.parm"
        self.truth_log = tmp_path / "truth.lcm"
        self.fw_log = tmp_path / "fw.lcm"
        self.sim = self.fw = self.m = None
        self.texts = []
        self.backlog = []   # messages read while waiting for something else

    # ------------------------------------------------------------ processes
    def start_sim(self, *args, lockstep=True):
        a = ["--xp-port", self.xp_port, "--data-out", f"127.0.0.1:{self.xp_listen}",
             "--xplane-version", self.version, "--lcm", f"file://{self.truth_log}"]
        if lockstep:
            a.append("--lockstep")
        self.sim = self.launch("octo-sim", *a, *args)
        return self.sim

    def start_fw(self, *args):
        self.fw = self.launch(
            "octo-fw", "--xplane", f"127.0.0.1:{self.xp_port}", "--xp-listen", self.xp_listen,
            "--mavlink-listen", self.mav_port, "--gcs", f"127.0.0.1:{self.gcs_port}",
            "--actuation", self.actuation, "--params", self.params, "--lcm", f"file://{self.fw_log}",
            *args)
        return self.fw

    def connect(self):
        if self.m is None:
            self.m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{self.gcs_port}", source_system=255,
                                                source_component=190)
        hb = self.m.wait_heartbeat(timeout=10)
        assert hb is not None, "no HEARTBEAT from octo-fw"
        return hb

    def start(self, sim_args=(), fw_args=()):
        self.start_sim(*sim_args)
        self.start_fw(*fw_args)
        self.connect()

    def close_gcs(self):
        if self.m is not None:
            self.m.close()
            self.m = None

    # ------------------------------------------------------------ MAVLink
    def recv(self, types, timeout=2.0):
        for i, msg in enumerate(self.backlog):
            if msg.get_type() in types:
                return self.backlog.pop(i)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            msg = self.m.recv_match(blocking=True, timeout=0.05)
            if msg is None:
                continue
            t = msg.get_type()
            if t == "STATUSTEXT":
                self.texts.append(msg.text)
            if t in types:
                return msg
            if t in ("AUTOPILOT_VERSION", "PARAM_VALUE", "MISSION_COUNT", "FILE_TRANSFER_PROTOCOL",
                     "COMMAND_ACK"):
                self.backlog.append(msg)
                del self.backlog[:-50]
        return None

    def cmd(self, command, *params, timeout=3.0, confirmation=0, target_component=1):
        p = list(params) + [0.0] * (7 - len(params))
        self.backlog = [m for m in self.backlog
                        if not (m.get_type() == "COMMAND_ACK" and m.command == command)]
        start = len(self.texts)
        self.m.mav.command_long_send(1, target_component, command, confirmation, *p)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            msg = self.recv({"COMMAND_ACK"}, timeout=deadline - time.monotonic())
            if msg is not None and msg.command == command:
                self.recv(set(), timeout=0.02)   # collect the STATUSTEXT that follows
                return msg.result, self.texts[start:]
        return None, self.texts[start:]

    def arm_when_ready(self, timeout=10.0):
        """Arms as soon as octo-fw has complete frames (version known, rows seen)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            r, _ = self.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            if r == mavlink.MAV_RESULT_ACCEPTED:
                return
            time.sleep(0.1)
        raise AssertionError(f"could not arm; fw stderr:\n{self.fw.stderr()}")

    def takeoff_and_hold(self, height_m, timeout=10.0):
        """Arms when ready, takes off to height_m and waits for "Mode HOLD" (asserted)."""
        self.arm_when_ready()
        r, texts = self.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, height_m)
        assert r == mavlink.MAV_RESULT_ACCEPTED, texts
        deadline = time.monotonic() + timeout
        while "Mode HOLD" not in self.texts and time.monotonic() < deadline:
            self.recv(set(), timeout=0.05)
        assert "Mode HOLD" in self.texts, self.texts

    def param_list(self, timeout=10.0):
        self.m.mav.param_request_list_send(1, 0)
        got, count = {}, None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            msg = self.recv({"PARAM_VALUE"}, timeout=0.5)
            if msg is None:
                if count is not None and len(got) >= count:
                    break
                continue
            count = msg.param_count
            got[msg.param_index] = msg
            if len(got) >= count:
                break
        return count, got

    def param_get(self, name, timeout=2.0):
        self.m.mav.param_request_read_send(1, 1, name.encode(), -1)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            msg = self.recv({"PARAM_VALUE"}, timeout=deadline - time.monotonic())
            if msg is not None and msg.param_id == name:
                return msg
        return None

    def drain(self, seconds=0.05):
        """Reads what is queued (into the backlog), so that old answers are not taken for new."""
        self.recv(set(), timeout=seconds)

    def param_set(self, name, value, timeout=2.0):
        self.drain()
        self.backlog = [m for m in self.backlog
                        if not (m.get_type() == "PARAM_VALUE" and m.param_id == name)]
        start = len(self.texts)
        self.m.mav.param_set_send(1, 1, name.encode(), float(value), mavlink.MAV_PARAM_TYPE_REAL32)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            msg = self.recv({"PARAM_VALUE"}, timeout=deadline - time.monotonic())
            if msg is not None and msg.param_id == name:
                self.recv(set(), timeout=0.02)
                return msg, self.texts[start:]
        return None, self.texts[start:]


# ---------------------------------------------------------------- logs
def read_log(path, channel):
    import lcm
    from octo import fw_event_t, fw_frame_t, truth_t
    types = {"OCTO_TRUTH": truth_t, "OCTO_FW_FRAME": fw_frame_t, "OCTO_FW_EVENT": fw_event_t}
    out = []
    for ev in lcm.EventLog(str(path), "r"):
        if ev.channel == channel:
            out.append(types[channel].decode(ev.data))
    return out


def tilt_deg(q):
    """Tilt of body Z from vertical for q = [w, x, y, z] (either frame convention)."""
    w, x, y, z = q
    c = 1.0 - 2.0 * (x * x + y * y)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def wait_exit(proc, timeout):
    ok = wait_until(lambda: not proc.alive(), timeout=timeout, step=0.05)
    assert ok, f"{proc.name} still running after {timeout} s"
