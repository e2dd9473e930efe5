"""`octo-gcs identify` against a scripted MAVLink vehicle that follows the
identification interface (firmware/app/experiment.h): USER_1 -> IN_PROGRESS, phase
and result STATUSTEXTs, the results as OCTO_ID_RESULT messages (one lost, sent again on
MAV_CMD_REQUEST_MESSAGE), live NAMED_VALUE_FLOATs, final ACK, ID_* parameters.
The real firmware is flown by test_gcs_mission_e2e.py."""

import os
import threading
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from conftest import free_port  # noqa: E402
from octo_gcs import link  # noqa: E402,F401  (the octo dialect, with OCTO_ID_RESULT)
from octo_gcs.cli import main  # noqa: E402

mav = mavutil.mavlink

RESULTS = {"ID_KF_EST": 28.031, "ID_KF_SD": 0.009, "ID_KF_PLAIN": 25.6, "ID_KTAU_EST": 0.38702,
           "ID_KTAU_SD": 0.0001, "ID_KTAU_PLAIN": 0.353, "ID_IXX_EST": 0.0630, "ID_IXX_SD": 0.0002,
           "ID_IYY_EST": 0.0764, "ID_IYY_SD": 0.0002, "ID_IZZ_EST": 0.1010, "ID_IZZ_SD": 0.0004,
           "ID_VAL_NE_PRE": 0.29, "ID_VAL_FIT_PRE": 30.0, "ID_VAL_NE_POST": 0.03, "ID_VAL_FIT_POST": 93.0,
           "ID_RESULT": 15.0}


class ScriptedVehicle(threading.Thread):
    def __init__(self, gcs_port, hovering=True, oscillating=0, settle_s=None, settles=True):
        super().__init__(daemon=True)
        self.oscillating = oscillating   # experiment commands answered TEMPORARILY_REJECTED first
        self.settle_s = self.settle_s_was = settle_s  # an experiment waits this long for the hover
        self.settles = settles           # ... then starts, or fails saying why
        self.m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{gcs_port}", source_system=1,
                                            source_component=1)
        self.mode = 3 if hovering else 0
        self.params = {"VEH_KF": 20.0, "VEH_KTAU": 0.3, "VEH_IXX": 0.05, "VEH_IYY": 0.05, "VEH_IZZ": 0.05,
                       "VEH_MASS": 2.132, "VEH_GRAV": 9.796, "ID_EXC_TIME": 10.0, "ID_RSD_MAX": 0.01}
        self.params.update({k: 0.0 for k in RESULTS})
        self.script = []
        self.stop = False
        self.started = []
        self.requested = []   # MAV_CMD_REQUEST_MESSAGE's message ids
        self.ktau_accepted = True

    def send_param(self, name):
        names = list(self.params)
        self.m.mav.param_value_send(name.encode(), self.params[name], mav.MAV_PARAM_TYPE_REAL32,
                                    len(names), names.index(name))

    def text(self, s, severity=6):
        self.m.mav.statustext_send(severity, s.encode())

    def run(self):
        last_hb = 0.0
        while not self.stop:
            now = time.monotonic()
            if now - last_hb > 0.2:
                last_hb = now
                self.m.mav.heartbeat_send(mav.MAV_TYPE_OCTOROTOR, mav.MAV_AUTOPILOT_GENERIC,
                                          mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, self.mode, 4)
            while self.script and self.script[0][0] <= now:
                self.script.pop(0)[1]()
            msg = self.m.recv_match(blocking=True, timeout=0.01)
            if msg is None:
                continue
            t = msg.get_type()
            if t == "PARAM_REQUEST_LIST":
                for name in list(self.params):
                    self.send_param(name)
            elif t == "PARAM_REQUEST_READ":
                name = msg.param_id if msg.param_index == -1 else list(self.params)[msg.param_index]
                if name in self.params:
                    self.send_param(name)
            elif t == "COMMAND_LONG" and msg.command == mav.MAV_CMD_REQUEST_MESSAGE:
                self.requested.append(int(msg.param1))
                self.m.mav.command_ack_send(msg.command, mav.MAV_RESULT_ACCEPTED)
                for i in range(5):
                    self.send_result(i)
            elif t == "COMMAND_LONG" and msg.command == mav.MAV_CMD_USER_1:
                if self.mode != 3:
                    self.m.mav.command_ack_send(msg.command, mav.MAV_RESULT_DENIED)
                    self.text(f"Experiment {int(msg.param1)} refused: not hovering")
                    continue
                if self.oscillating > 0:
                    self.oscillating -= 1
                    self.m.mav.command_ack_send(msg.command, mav.MAV_RESULT_TEMPORARILY_REJECTED)
                    self.text(f"Experiment {int(msg.param1)} refused: attitude oscillating (30 deg/s rms)")
                    continue
                self.m.mav.command_ack_send(msg.command, mav.MAV_RESULT_IN_PROGRESS, 0)
                if self.settle_s is not None:   # as octo-fw: IN_PROGRESS, then the wait said
                    n, self.settle_s, t0 = int(msg.param1), None, time.monotonic()
                    self.text(f"Experiment {n} waits: height +0.40 m off (0.30)")
                    self.script = [(t0 + self.settle_s_was, self.wait_end(n))]
                    continue
                self.begin(int(msg.param1))

    def begin(self, n):
        self.started.append(n)
        self.mode = 4
        self.plan(time.monotonic())

    def wait_end(self, n):
        if self.settles:
            return lambda: self.begin(n)
        return lambda: (self.text(f"Experiment {n} not started: 30 s, height +0.40 m off", 3),
                        self.m.mav.command_ack_send(mav.MAV_CMD_USER_1, mav.MAV_RESULT_FAILED))

    def send_result(self, i):
        """Result i of run 1: k_f, k_tau, I_x, I_y, I_z (from the thrust rows)."""
        name, est, sd = [("KF", "ID_KF_EST", "ID_KF_SD"), ("KTAU", "ID_KTAU_EST", "ID_KTAU_SD"),
                         ("IXX", "ID_IXX_EST", "ID_IXX_SD"), ("IYY", "ID_IYY_EST", "ID_IYY_SD"),
                         ("IZZ", "ID_IZZ_EST", "ID_IZZ_SD")][i]
        ok = self.ktau_accepted or name != "KTAU"
        self.m.mav.octo_id_result_send(0, 1, i, i + 1, int(i == 4), 1 if i < 2 else i, getattr(mav, f"OCTO_ID_PARAM_{name}"),
                                       0, RESULTS[est], RESULTS[sd], int(ok),
                                       mav.OCTO_ID_REASON_OK if ok else mav.OCTO_ID_REASON_UNCERTAIN,
                                       mav.OCTO_ID_SOURCE_THRUST)

    def plan(self, t0):
        steps = [lambda: self.text("Mode EXPERIMENT")]
        for k, name in enumerate(["validation", "rotor coefficients", "validation", "Ix", "Iy", "Iz"], 1):
            steps.append(lambda k=k, name=name: self.text(f"ID {k}/6: {name}"))
        for i in range(5):
            steps.append(lambda i=i: (self.m.mav.named_value_float_send(0, b"KF", 28.0 + 0.1 / (i + 1)),
                                      self.m.mav.named_value_float_send(0, b"KF_SD", 0.05 / (i + 1))))
        steps.append(lambda: self.text("ID kf 28.03 +/- 0.01 N accepted"))
        steps += [lambda i=i: self.send_result(i) for i in (0, 1, 2, 4)]   # result 3 (I_y) is lost
        steps.append(lambda: (self.params.update(RESULTS), self.params.update(
            {"VEH_KF": RESULTS["ID_KF_EST"], "VEH_KTAU": RESULTS["ID_KTAU_EST"], "VEH_IXX": RESULTS["ID_IXX_EST"],
             "VEH_IYY": RESULTS["ID_IYY_EST"], "VEH_IZZ": RESULTS["ID_IZZ_EST"]})))
        steps.append(lambda: self.m.mav.command_ack_send(mav.MAV_CMD_USER_1, mav.MAV_RESULT_ACCEPTED))
        steps.append(lambda: self.text("ID done"))
        steps.append(lambda: (setattr(self, "mode", 3), self.text("Mode HOLD")))
        self.script = [(t0 + 0.03 * i, f) for i, f in enumerate(steps)]


@pytest.fixture
def vehicle():
    started = []

    def make(**kw):
        port = free_port()
        v = ScriptedVehicle(port, **kw)
        v.start()
        started.append(v)
        return v, f"udpin:127.0.0.1:{port}"
    yield make
    for v in started:
        v.stop = True
        v.join(timeout=2)
        v.m.close()


def test_identify_runs_the_sequence_and_passes(vehicle, capsys, tmp_path):
    v, url = vehicle()
    truth = tmp_path / "truth.json"
    truth.write_text("{}")   # the paper's vehicle
    rc = main(["identify", "--connect", url, "--expect", str(truth)])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert v.started == [6]
    assert "ID 2/6 rotor coefficients" in out            # progress (plain lines: not a TTY)
    assert "KF 28.0" in out and "+/-" in out             # live estimate with its std
    assert "ID kf 28.03 +/- 0.01 N accepted" in out
    assert "k_f vs truth" in out and "PASS" in out
    assert v.requested == [54000]   # the lost result asked for again
    assert "results: (from thrust)" in out and "rejected" not in out


def test_identify_names_the_firmwares_reason(vehicle, capsys):
    v, url = vehicle()
    v.ktau_accepted = False
    main(["identify", "--connect", url, "--experiments", "1"])
    out = capsys.readouterr().out
    assert "rejected: uncertain" in out.split("checks:")[0], out


def test_identify_fails_against_another_truth(vehicle, capsys, tmp_path):
    v, url = vehicle()
    truth = tmp_path / "truth.json"
    truth.write_text('{"kf": 27.0}')
    assert main(["identify", "--connect", url, "--expect", str(truth), "--experiments", "1"]) == 1
    out = capsys.readouterr().out
    assert "[FAIL] k_f vs truth" in out and "FAIL" in out.splitlines()[-1]


def test_identify_waits_while_the_attitude_oscillates(vehicle, capsys):
    """The firmware refuses an experiment with TEMPORARILY_REJECTED while its oscillation
    guard lowers the attitude gain: identify asks again until it starts."""
    v, url = vehicle(oscillating=3)
    assert main(["identify", "--connect", url, "--experiments", "1"]) == 0, capsys.readouterr()
    assert v.started == [1] and v.oscillating == 0


def test_identify_waits_while_the_vehicle_waits_for_the_hover(vehicle, capsys):
    """IN_PROGRESS and "Experiment 1 waits: ..." with the vehicle in HOLD for longer than
    identify's 2 s grace for a vehicle that left the experiment mode: it is not taken for an
    ended experiment; the experiment starts 3 s later and passes."""
    v, url = vehicle(settle_s=3.0)
    assert main(["identify", "--connect", url, "--experiments", "1"]) == 0, capsys.readouterr()
    assert v.started == [1]
    assert "Experiment 1 waits: height +0.40 m off (0.30)" in capsys.readouterr().out


def test_identify_fails_with_the_vehicles_reason_when_it_never_hovers(vehicle, capsys):
    v, url = vehicle(settle_s=3.0, settles=False)
    assert main(["identify", "--connect", url, "--experiments", "1"]) == 1
    err = capsys.readouterr().err
    assert "Experiment 1 not started: 30 s, height +0.40 m off" in err, err
    assert v.started == [] and "Traceback" not in err


def test_identify_refuses_a_vehicle_on_the_ground(vehicle, capsys):
    v, url = vehicle(hovering=False)
    assert main(["identify", "--connect", url]) == 1
    err = capsys.readouterr().err
    assert "not HOLD" in err and "Traceback" not in err and v.started == []


def test_identify_without_a_vehicle_says_so(capsys):
    port = free_port()
    assert main(["identify", "--connect", f"udpin:127.0.0.1:{port}", "--timeout", "0.5"]) == 1
    err = capsys.readouterr().err
    assert f"no heartbeat from a vehicle on udpin:127.0.0.1:{port} after 0.5 s" in err


def test_bad_arguments_are_user_errors(capsys, tmp_path):
    assert main(["identify", "--experiments", "9", "--connect", "udpin:127.0.0.1:1"]) == 1
    assert "experiment 9 unknown" in capsys.readouterr().err
    bad = tmp_path / "v.json"
    bad.write_text('{"kf": -3}')
    assert main(["identify", "--expect", str(bad)]) == 1
    assert "'kf' must be a positive number" in capsys.readouterr().err
    assert main(["mission", "--vehicle", str(bad), "--out", str(tmp_path / "o")]) == 1
    assert "'kf'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    for cmd in ("identify", "mission", "plot"):
        with pytest.raises(SystemExit) as e:
            main([cmd, "--help"])
        assert e.value.code == 0
        assert "usage: octo-gcs " + cmd in capsys.readouterr().out
