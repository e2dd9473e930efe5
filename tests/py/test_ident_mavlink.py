"""Identification over MAVLink (the interface shared with octo-gcs): command
acknowledgements (DENIED unless hovering, IN_PROGRESS with progress, final ACCEPTED/FAILED),
STATUSTEXT lines, live NAMED_VALUE_FLOAT, result parameters (read-only) and VEH_* applied,
broadcast and saved."""

import struct
import time

import pytest

from ident_helpers import MAV_CMD_USER_1, IdentFlight, false_alarm, mavlink


def test_rotor_experiment_over_mavlink(launch, port, tmp_path):
    fl = IdentFlight(launch, port, tmp_path, seed=31, params={"ID_EXC_TIME": 30})
    rig = fl.rig
    rig.arm_when_ready()
    r, texts = rig.cmd(MAV_CMD_USER_1, 1)
    assert r == mavlink.MAV_RESULT_DENIED, texts          # armed on the ground: not hovering
    r, _ = rig.cmd(MAV_CMD_USER_1, 9)
    assert r == mavlink.MAV_RESULT_DENIED
    fl.takeoff()
    r, _ = rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 251, 20000)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    start = len(rig.texts)
    rig.m.mav.command_long_send(1, 1, MAV_CMD_USER_1, 0, 1, 0, 0, 0, 0, 0, 0)
    acks, named, values = [], {}, {}
    deadline = time.monotonic() + 60
    retried = False
    while time.monotonic() < deadline:
        m = rig.recv({"COMMAND_ACK", "NAMED_VALUE_FLOAT", "PARAM_VALUE"}, timeout=0.1)
        if m is None:
            continue
        t = m.get_type()
        if t == "COMMAND_ACK" and m.command == MAV_CMD_USER_1:
            acks.append((m.result, m.progress))
            if not retried:   # a retry (confirmation 1) while it runs: IN_PROGRESS again
                time.sleep(0.1)
                rig.m.mav.command_long_send(1, 1, MAV_CMD_USER_1, 1, 1, 0, 0, 0, 0, 0, 0)
                retried = True
            if m.result != mavlink.MAV_RESULT_IN_PROGRESS:
                break
        elif t == "NAMED_VALUE_FLOAT":
            named.setdefault(m.name, []).append(m.value)
        elif t == "PARAM_VALUE":
            values[m.param_id] = m.param_value
    rig.recv(set(), timeout=0.3)
    texts = rig.texts[start:]
    print(acks, sorted(named), texts)
    assert acks[0][0] == mavlink.MAV_RESULT_IN_PROGRESS
    assert acks[1][0] == mavlink.MAV_RESULT_IN_PROGRESS and acks[1][1] > 0
    assert acks[-1][0] == mavlink.MAV_RESULT_ACCEPTED
    assert "ID 1/1: rotor coefficients" in texts
    assert texts.index("ID done") > texts.index("ID 1/1: rotor coefficients")
    for n in ("KF", "KF_SD", "KTAU", "KTAU_SD", "KF_PLAIN", "KTAU_PLAIN"):
        assert n in named, sorted(named)
    assert "IXX" not in named                 # only what the phase estimates
    assert abs(named["KF"][-1] / 28.0269 - 1) < 0.01
    if false_alarm(texts):   # the whiteness test's known false rejections (ident_helpers)
        print("whiteness rejected the motor model: flown again")
        texts = fl.experiment(1, again=False)
        values = {n: fl.param(n) for n in ("VEH_KF", "ID_RESULT")}
    assert any(t.startswith("ID kf ") and t.endswith("accepted") for t in texts), texts
    # applied, broadcast, saved
    assert abs(values.get("VEH_KF", 0) / 28.0269 - 1) < 3e-3, values
    assert values.get("ID_RESULT") == 1.0
    kf = fl.param("ID_KF_EST")
    assert fl.param("VEH_KF") == kf
    saved = dict(line.split() for line in rig.params.read_text().splitlines()
                 if line.strip() and not line.startswith("#"))
    f32 = lambda x: struct.unpack("f", struct.pack("f", float(x)))[0]   # noqa: E731
    assert f32(saved["VEH_KF"]) == kf and f32(saved["ID_KF_EST"]) == kf
    # results are read-only; configuration is writable when no experiment runs
    m, texts = rig.param_set("ID_KF_EST", 1.0)
    assert m is not None and m.param_value == kf and texts
    m, _ = rig.param_set("ID_EXC_TIME", 5.0)
    assert m is not None and m.param_value == 5.0
    fl.finish()


def test_rejection_and_attitude_abort(launch, port, tmp_path):
    """An estimate whose relative std exceeds ID_RSD_MAX is reported but not applied; an
    excitation that tilts the vehicle beyond the limit aborts (FAILED, back to hold, nothing
    applied)."""
    # lockstep runs as fast as the pair can: the ground station's exchanges between the two
    # experiments may cost the plant well over 100 s, so its clock gets room (not 200 s)
    # without the throttle sweep: k_f's std (0.4 %, not 0.2 %) then stays beyond what the
    # phase's extension (at most 4 times as long) can bring to ID_RSD_MAX's smallest value
    fl = IdentFlight(launch, port, tmp_path, seed=41, params={"ID_RSD_MAX": 0.0001, "ID_SWP_THR": 0.0},
                     duration=1000.0)
    rig = fl.rig
    fl.takeoff()
    texts = fl.experiment(1)
    assert any(t.startswith("ID kf ") and "rejected: std too large" in t for t in texts), texts
    assert fl.param("VEH_KF") == 20.0
    assert abs(fl.param("ID_KF_EST") / 28.0269 - 1) < 3e-3
    assert fl.param("ID_RESULT") == 0.0
    # 5 N m of roll torque on a softened attitude loop: beyond the attitude limit faster than
    # the back-off takes it out (at the default ATT_WN_RP the excitation's fade-in gives the
    # back-off the time, and the phase completes)
    m, _ = rig.param_set("ID_INR_AMP", 5.0)
    assert m is not None and m.param_value == 5.0
    m, _ = rig.param_set("ATT_WN_RP", 4.0)
    assert m is not None and m.param_value == 4.0
    start = len(rig.texts)
    r, _ = rig.cmd(MAV_CMD_USER_1, 3)
    assert r == mavlink.MAV_RESULT_IN_PROGRESS
    final = None
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and final is None:
        a = rig.recv({"COMMAND_ACK"}, timeout=0.2)
        if a is not None and a.command == MAV_CMD_USER_1 and a.result != mavlink.MAV_RESULT_IN_PROGRESS:
            final = a.result
    rig.recv(set(), timeout=0.3)
    texts = rig.texts[start:]
    print(texts)
    assert final == mavlink.MAV_RESULT_FAILED
    assert any(t.startswith("ID aborted") and "attitude" in t for t in texts), texts
    assert "Mode HOLD" in texts
    assert fl.param("VEH_IXX") == pytest.approx(0.05)
    fl.finish()
