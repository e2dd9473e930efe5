"""Identification results as data: a lockstep flight of octo-sim + octo-fw runs the rotor
experiment and validation; the results are read as OCTO_ID_RESULT (MAV_CMD_REQUEST_MESSAGE
54000, param2 -1: the last run) with pymavlink and as octo.fw_id_result_t records of the
firmware's LCM log, and checked against the result parameters (ID_KF_EST, ID_KF_SD, ...)
and the codes of docs/mavlink.md. No regular expression over STATUSTEXT is involved."""

import math
import time

import pytest
from pymavlink import mavutil

from ident_helpers import IdentFlight

mavlink = None   # the dialect octo's module, while a test runs (octo_dialect)

ID_RESULT = 54000


def request_results(rig, index=-1, timeout=5.0):
    """MAV_CMD_REQUEST_MESSAGE for OCTO_ID_RESULT: its COMMAND_ACK result and the messages."""
    rig.m.mav.command_long_send(1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, ID_RESULT, index, 0, 0, 0, 0, 0)
    result, got = None, []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = rig.m.recv_match(type=["COMMAND_ACK", "OCTO_ID_RESULT"], blocking=True, timeout=0.2)
        if m is None:
            if result is not None:
                break   # the answer is complete
            continue
        if m.get_type() == "COMMAND_ACK" and m.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            result = m.result
            if result != mavlink.MAV_RESULT_ACCEPTED:
                break
        elif m.get_type() == "OCTO_ID_RESULT" and result is not None:
            got.append(m)
    return result, got


def fw_id_records(path):
    import lcm
    from octo import fw_id_result_t
    return [fw_id_result_t.decode(ev.data) for ev in lcm.EventLog(str(path), "r")
            if ev.channel == "OCTO_FW_ID_RESULT"]


@pytest.fixture
def octo_dialect():
    """The project's dialect for the rig's connection (OCTO_ID_RESULT is not in common)."""
    global mavlink
    before = mavutil.current_dialect
    mavutil.set_dialect("octo")
    mavlink = mavutil.mavlink
    yield
    mavutil.set_dialect(before)


def test_rotor_experiment_results_as_data(launch, port, tmp_path, octo_dialect):
    # two experiments and the ground station's requests between them (lockstep: plant time
    # runs on while it waits): the plant's 200 s default can run out
    fl = IdentFlight(launch, port, tmp_path, seed=5, duration=600)
    fl.takeoff()
    r, got = request_results(fl.rig)
    assert r == mavlink.MAV_RESULT_FAILED and not got   # no run yet
    texts = fl.experiment(1)
    assert "ID done" in texts
    r, got = request_results(fl.rig)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    by = {(m.param, m.rotor): m for m in got}
    assert [m.index for m in got] == list(range(len(got)))
    assert all(m.run_id == 1 and m.count == len(got) and m.experiment == 1 for m in got)
    assert got[-1].run_done == 1 and all(m.run_done == 0 for m in got[:-1])
    assert all(m.source == mavlink.OCTO_ID_SOURCE_THRUST for m in got)

    kf = by[(mavlink.OCTO_ID_PARAM_KF, 0)]
    ktau = by[(mavlink.OCTO_ID_PARAM_KTAU, 0)]
    assert kf.value == fl.param("ID_KF_EST") and kf.sd == fl.param("ID_KF_SD")
    assert ktau.value == fl.param("ID_KTAU_EST") and ktau.sd == fl.param("ID_KTAU_SD")
    accepted = (int(fl.param("ID_RESULT")) & 1) == 1
    assert kf.accepted == ktau.accepted == int(accepted)
    if accepted:
        assert kf.reason == ktau.reason == mavlink.OCTO_ID_REASON_OK
        assert fl.param("VEH_KF") == kf.value and fl.param("VEH_KTAU") == ktau.value
    else:
        assert kf.reason != mavlink.OCTO_ID_REASON_OK
    for name, p in (("ID_KF_PLAIN", mavlink.OCTO_ID_PARAM_KF_PLAIN),
                    ("ID_KTAU_PLAIN", mavlink.OCTO_ID_PARAM_KTAU_PLAIN)):
        m = by[(p, 0)]
        assert m.value == fl.param(name) and m.accepted == 0
        assert m.reason == mavlink.OCTO_ID_REASON_AUXILIARY and math.isnan(m.sd)
    lag = by[(mavlink.OCTO_ID_PARAM_MOT_TAU, 0)]
    assert lag.value == fl.param("ID_TAU_CHECK") and lag.sd == fl.param("ID_TAU_SD")
    assert (mavlink.OCTO_ID_PARAM_DELAY_FR, 0) in by
    assert (mavlink.OCTO_ID_PARAM_MOT_CURVE, 0) not in by   # ID_CRV_EST 0: the curve is given
    for j in range(1, 9):
        s = by[(mavlink.OCTO_ID_PARAM_MOT_SCALE, j)]
        assert s.accepted == int(accepted)
        if accepted:
            assert fl.param(f"MOT_SCALE{j}") == s.value

    # one result by its index: the same values
    r, one = request_results(fl.rig, index=1)
    assert r == mavlink.MAV_RESULT_ACCEPTED and len(one) == 1
    assert (one[0].param, one[0].value, one[0].index) == (got[1].param, got[1].value, 1)
    assert request_results(fl.rig, index=len(got))[0] == mavlink.MAV_RESULT_FAILED

    # validation: run 2, the NE with the fit % in sd's place
    texts = fl.experiment(2)
    assert "ID done" in texts, texts
    r, val = request_results(fl.rig)
    assert r == mavlink.MAV_RESULT_ACCEPTED and len(val) == 1
    v = val[0]
    assert v.run_id == 2 and v.experiment == 2 and v.run_done == 1
    post = accepted
    assert v.param == (mavlink.OCTO_ID_PARAM_VAL_NE_AFTER if post else mavlink.OCTO_ID_PARAM_VAL_NE_BEFORE)
    sfx = "POST" if post else "PRE"
    assert v.value == fl.param(f"ID_VAL_NE_{sfx}") and v.sd == fl.param(f"ID_VAL_FIT_{sfx}")
    assert v.accepted == 1 and v.reason == mavlink.OCTO_ID_REASON_OK
    fl.finish()

    # the LCM log holds the same records, as they were published
    recs = fw_id_records(fl.rig.fw_log)
    assert len(recs) == len(got) + 1
    for rec, m in zip(recs, got + val):
        assert (rec.run_id, rec.index, rec.param, rec.rotor) == (m.run_id, m.index, m.param, m.rotor)
        assert rec.value == m.value and (rec.sd == m.sd or (math.isnan(rec.sd) and math.isnan(m.sd)))
        assert (rec.accepted, rec.reason, rec.source, rec.experiment) == (m.accepted, m.reason, m.source,
                                                                           m.experiment)
    assert recs[len(got) - 1].run_done == 1 and recs[-1].run_done == 1
