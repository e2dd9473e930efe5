"""Helpers of the identification tests, no tests: fly octo-sim + octo-fw in
lockstep, run MAV_CMD_USER_1 experiments, read the results from parameters, STATUSTEXT and
both LCM logs.

    fl = IdentFlight(launch, port, tmp_path, vehicle={...}, seed=3)
    fl.takeoff()
    res = fl.experiment(1)          # waits for the final "ID done" / "ID aborted"
    fl.finish()                     # stops both, reads the logs (fl.truth, fl.frames)
"""

import json
import math
import time

from conftest import draw_inertia
from test_fw_rig import Rig, mavlink, read_log, tilt_deg

PAPER = dict(mass=2.132, kf=28.0269, ktau=0.3869, inertia=[0.0628, 0.0762, 0.1014])
TAKEOFF_M = 5.0
MAV_CMD_USER_1 = 31010


def random_vehicle(rng):
    """Truth within +/-30 % of the paper's values (mass kept: it is a known parameter)."""
    v = dict(kf=PAPER["kf"] * rng.uniform(0.7, 1.3), ktau=PAPER["ktau"] * rng.uniform(0.7, 1.3))
    return dict(v, inertia=draw_inertia(lambda: [i * rng.uniform(0.7, 1.3) for i in PAPER["inertia"]]))


def fw_said(text):
    """The firmware's lines ("octo-fw: ...", its stderr or a log of it) without the prefix."""
    return [ln.split("octo-fw: ", 1)[1] for ln in text.splitlines() if "octo-fw: " in ln]


def coloured(texts):
    return [t for t in texts if t.startswith("ID whiteness ") and t.endswith(": coloured")]


def false_alarm(texts):
    """The motor model rejected by its whiteness test alone (over everything, one throttle
    level or one rotor's series), no other cause named (range, curve, delay, noise)."""
    rejected = [t for t in texts if t.startswith("ID rejected: ")]
    white = ("ID rejected: residuals not white", "ID rejected: residuals coloured at one throttle level")
    return bool(coloured(texts)) and bool(rejected) and all(
        t in white or (t.startswith("ID rejected: rotor ") and " unexplained" in t) for t in rejected)


class IdentFlight:
    def __init__(self, launch, port, tmp_path, vehicle=None, seed=1, ideal=False, params=None,
                 duration=200.0, extra_sim_args=(), lockstep=True):
        self.rig = Rig(launch, port, tmp_path)
        self.tmp = tmp_path
        self.vehicle = vehicle
        sim_args = ["--duration", duration, "--seed", seed]
        if vehicle is not None:
            vf = tmp_path / "vehicle.json"
            vf.write_text(json.dumps(vehicle))
            sim_args += ["--vehicle", vf]
        if ideal:
            sim_args.append("--ideal")
        sim_args += list(extra_sim_args)
        # a loaded test machine can stall a lockstep pair for a few hundred ms of wall time:
        # a link timeout of 1 s keeps that from aborting experiments
        # the vehicles of these tests have a linear thrust curve unless they say otherwise:
        # it is declared (ID_CRV_EST 0, MOT_CURVE 0), so k_f is not an extrapolation through
        # an estimated curve (tests of the curve pass ID_CRV_EST 1)
        params = {"FS_LINK_TO": 1.0, "ID_CRV_EST": 0, **(params or {})}
        self.rig.params.write_text("".join(f"{k} {v}\n" for k, v in params.items()))
        self.rig.start_sim(*sim_args, lockstep=lockstep)
        self.rig.start_fw()
        self.rig.connect()
        self.texts_seen = 0

    def takeoff(self, height=TAKEOFF_M, timeout=60.0):
        rig = self.rig
        rig.arm_when_ready()
        r, texts = rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, height)
        assert r == mavlink.MAV_RESULT_ACCEPTED, texts
        self.wait_text(lambda t: t == "Mode HOLD", timeout)
        time.sleep(0.3)   # settle (lockstep: many simulated seconds)

    def wait_text(self, pred, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for t in self.rig.texts[self.texts_seen:]:
                self.texts_seen += 1
                if pred(t):
                    return t
            self.rig.recv({"STATUSTEXT"}, timeout=0.2)
        raise AssertionError(f"timed out; texts: {self.rig.texts[-20:]}\nfw: {self.rig.fw.stderr()[-2000:]}")

    def experiment(self, exp_id, timeout=120.0, again=True):
        """Starts experiment exp_id; returns the texts of the experiment.

        The motor model's whiteness test rejects a vehicle the model describes at a small,
        known rate (its false rejections, bench item 5). With `again`, a run whose only fault
        is that test's rejection is flown once more, as a user would, and the second run's texts
        are returned. Values are still judged against the truth: a vehicle the model does not
        describe is rejected again."""
        texts = self._experiment(exp_id, timeout)
        if again and false_alarm(texts):
            print(f"experiment {exp_id}: whiteness rejected the motor model ({coloured(texts)}): flown again")
            texts = self._experiment(exp_id, timeout)
        return texts

    def _experiment(self, exp_id, timeout):
        start = len(self.rig.texts)
        deadline = time.monotonic() + 10
        while True:
            r, _ = self.rig.cmd(MAV_CMD_USER_1, exp_id)
            if r in (mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_IN_PROGRESS):
                break
            assert time.monotonic() < deadline, f"experiment {exp_id} refused: {r} {self.rig.texts[-5:]}"
            time.sleep(0.2)
        self.texts_seen = start
        self.wait_text(lambda t: t == "ID done" or t.startswith("ID aborted"), timeout)
        self.rig.recv(set(), timeout=0.3)
        return self.rig.texts[start:]

    def param(self, name):
        # PARAM_VALUEs broadcast earlier wait in the rig's backlog: ask for the current value
        self.rig.backlog = [m for m in self.rig.backlog if m.get_type() != "PARAM_VALUE"]
        m = self.rig.param_get(name)
        assert m is not None, f"no {name}"
        return m.param_value

    def finish(self):
        self.rig.sim.stop()
        self.rig.fw.stop()
        self.truth = read_log(self.rig.truth_log, "OCTO_TRUTH")
        self.frames = read_log(self.rig.fw_log, "OCTO_FW_FRAME")
        self.events = read_log(self.rig.fw_log, "OCTO_FW_EVENT")


def exp_window(frames, exp_id):
    """Frames of the flight log while experiment exp_id ran (stepped frames)."""
    return [f for f in frames if f.stepped and f.exp_id == exp_id]


def plain_closed_form(frames, truth, kf_true):
    """The notes' closed form of the plain estimator's bias, evaluated on the flight:
    d = T_1 - mean(T_1) (commands while excited), d_lag = s_1 - mean(s_1) with s_1 what rotor 1's
    thrust saw at the same frame (truth thrust / k_f)."""
    by_t = {round(s.t, 4): s for s in truth}
    T, S = [], []
    for f in frames:
        s = by_t.get(round(f.t, 4))
        if s is None:
            continue
        T.append(f.throttle[0])
        S.append(s.thrust[0] / kf_true)
    n = len(T)
    mt, ms = sum(T) / n, sum(S) / n
    ed2 = sum((t - mt) ** 2 for t in T) / n
    eddl = sum((t - mt) * (s - ms) for t, s in zip(T, S)) / n
    return -(ed2 - eddl) / (mt * mt + ed2), n


__all__ = ["IdentFlight", "PAPER", "random_vehicle", "exp_window", "plain_closed_form", "tilt_deg",
           "mavlink", "math"]
