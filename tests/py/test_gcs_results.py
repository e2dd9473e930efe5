"""The firmware's identification results as data: octo-gcs reads OCTO_ID_RESULT messages
(MAVLink, dialect octo) and octo.fw_id_result_t records (fw.lcm) into the ID_* values, the
reasons and the source of the report and the campaign, with no text parsed. The messages and
records here are built with pymavlink's and lcm-gen's own types and go through their encoders."""

import math
import random
import sys
import types

import pytest

from conftest import BUILD

sys.path.insert(0, str(BUILD / "gen" / "python"))

import lcm  # noqa: E402
from octo import fw_id_result_t  # noqa: E402

from octo_gcs import campaign, campaign_spec, id_results  # noqa: E402
from octo_gcs.link import mavlink  # noqa: E402
from octo_gcs.logs import Logs  # noqa: E402
from octo_gcs.mission import report  # noqa: E402
from octo_gcs.vehiclefile import load  # noqa: E402

P, R, S = "OCTO_ID_PARAM_", "OCTO_ID_REASON_", "OCTO_ID_SOURCE_"


def results(rng):
    """(param, rotor, value, sd, accepted, reason) of a made-up sequence 6, k_tau rejected."""
    kf = rng.uniform(20.0, 35.0)
    return [("VAL_NE_BEFORE", 0, 0.31, 12.5, 0, "AUXILIARY"),
            ("KF", 0, kf, kf * 1e-3, 0, "PARTNER_REJECTED"), ("KTAU", 0, kf / 72.4, 1e-2, 0, "UNCERTAIN"),
            ("KF_PLAIN", 0, kf * 0.94, math.nan, 0, "AUXILIARY"), ("MOT_SCALE", 3, 0.987, 0.004, 1, "OK"),
            ("VAL_NE_AFTER", 0, 0.02, 95.0, 0, "AUXILIARY"),
            ("IXX", 0, 0.0631, 2e-4, 1, "OK"), ("IYY", 0, 0.0765, 2e-4, 1, "OK"), ("IZZ", 0, 0.1012, 4e-4, 1, "OK")]


def fields(rows, i, source="IMU_RPM"):
    param, rotor, value, sd, acc, reason = rows[i]
    exp = {"VAL_NE_BEFORE": 2, "VAL_NE_AFTER": 2, "IXX": 3, "IYY": 4, "IZZ": 5}.get(param, 1)
    return dict(run_id=1, index=i, count=i + 1, run_done=int(i == len(rows) - 1), experiment=exp,
                param=getattr(mavlink, P + param), rotor=rotor, value=value, sd=sd, accepted=acc,
                reason=getattr(mavlink, R + reason), source=getattr(mavlink, S + source))


def over_mavlink(f):
    """A MAVLink_octo_id_result_message packed and parsed again (as it crosses the link)."""
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    msg = mavlink.MAVLink_octo_id_result_message(time_boot_ms=1234, **f)
    return mav.decode(bytearray(msg.pack(mav)))


def check_reading(recs, rows):
    f32 = lambda x: float(mavlink.struct.unpack("<f", mavlink.struct.pack("<f", x))[0])  # noqa: E731
    p = id_results.to_params(recs)
    assert p["ID_KF_EST"] == f32(rows[1][2]) and p["ID_KF_SD"] == f32(rows[1][3])
    assert p["ID_KTAU_EST"] == f32(rows[2][2]) and p["ID_KF_PLAIN"] == f32(rows[3][2])
    assert "ID_KTAU_PLAIN" not in p and p["MOT_SCALE3"] == f32(0.987)
    assert p["ID_VAL_NE_PRE"] == f32(0.31) and p["ID_VAL_FIT_PRE"] == f32(12.5)
    assert p["ID_VAL_NE_POST"] == f32(0.02) and p["ID_VAL_FIT_POST"] == f32(95.0)
    assert p["ID_RESULT"] == 14.0   # k_tau rejected: k_f's and k_tau's bit off, the inertias' on
    v = id_results.verdicts(recs)
    assert v["kf"] == {"accepted": False, "reason": "partner_rejected", "source": "imu_rpm"}
    assert v["ktau"] == {"accepted": False, "reason": "uncertain", "source": "imu_rpm"}
    assert id_results.rejections(recs) == {"kf": "partner_rejected", "ktau": "uncertain"}
    assert id_results.estimator_source(recs) == "imu_rpm"
    merged, filled = id_results.merge({"ID_KF_EST": 1.0, "VEH_KF": 1.0}, recs)
    assert merged["ID_KF_EST"] == 1.0 and "ID_KF_EST" not in filled and "ID_IZZ_EST" in filled


def test_mavlink_messages_are_read_as_data():
    rng = random.Random()
    rows = results(rng)
    order = list(range(len(rows)))
    lost = rng.choice(order[:-1])
    col = id_results.Collector()
    for i in order:
        if i != lost:
            col.add(over_mavlink(fields(rows, i)))
    assert col.missing(1) == [lost]
    col.add(over_mavlink(fields(rows, lost)))   # asked for again
    col.add(over_mavlink(fields(rows, 0)))      # a copy replaces the first
    assert col.missing(1) == [] and len(col) == len(rows) and col.runs() == [1]
    check_reading(col.records(), rows)
    # the names come from the dialect's enums, every entry of them
    for code, entry in mavlink.enums["OCTO_ID_REASON"].items():
        assert id_results.reason_name(code) == entry.name[len(R):].lower()
    assert id_results.source_name(mavlink.OCTO_ID_SOURCE_IMU_RPM_TORQUE) == "imu_rpm_torque"
    assert id_results.reason_name(999) == "octo_id_reason 999"


def write_log(path, rows, source="IMU_RPM"):
    log = lcm.EventLog(str(path), "w", overwrite=True)
    for i in range(len(rows)):
        r = fw_id_result_t()
        for k, v in fields(rows, i, source).items():
            setattr(r, k, v)
        r.utime = 1_000_000 * (10 + i)
        log.write_event(r.utime, "OCTO_FW_ID_RESULT", r.encode())
    log.close()


def test_lcm_records_are_read_as_data(tmp_path):
    rows = results(random.Random())
    write_log(tmp_path / "fw.lcm", rows)
    recs = Logs([tmp_path / "fw.lcm"]).id_results   # one file: the arrays' path
    assert [r["index"] for r in recs] == list(range(len(rows)))
    check_reading(recs, rows)
    write_log(tmp_path / "fw2.lcm", rows)
    two = Logs([tmp_path / "fw.lcm", tmp_path / "fw2.lcm"]).id_results   # record by record
    assert [id_results.describe(r) for r in two[: len(rows)]] == [id_results.describe(r) for r in recs]


def test_report_and_campaign_row_carry_reasons_and_source(tmp_path):
    rows = results(random.Random())
    write_log(tmp_path / "fw.lcm", rows)
    recs = Logs([tmp_path / "fw.lcm"]).id_results
    after, filled = id_results.merge({"VEH_MASS": 2.132, "VEH_GRAV": 9.796, "ID_RSD_MAX": 0.01}, recs)
    opts = types.SimpleNamespace(vehicle=None, seed=1, realtime=False, xplane_version=12)
    rep = report.build_report(tmp_path, load(None), opts, {}, after, [6], logs=None, filled=filled, results=recs)
    assert rep["estimator"]["source"] == "imu_rpm"
    kt = rep["parameters"]["ktau"]
    assert kt["accepted"] is False and kt["reason"] == "uncertain" and kt["source"] == "imu_rpm"
    assert rep["parameters"]["kf"]["accepted"] is False and rep["parameters"]["kf"]["reason"] == "partner_rejected"
    assert rep["parameters"]["ixx"]["accepted"] and rep["parameters"]["ixx"]["reason"] == "ok"
    assert [r["param"] for r in rep["id_results"]][:3] == ["val_ne_before", "kf", "ktau"]
    assert rep["id_results"][3]["sd"] is None   # NaN: none defined
    assert "no: uncertain" in report.table_text(rep)
    assert "Estimated from: IMU and rotor speed (source imu_rpm)" in report.table_text(rep)
    assert "Estimated from: IMU and rotor speed (source imu_rpm)." in report.markdown(rep)
    assert rep["results_from_records"] == filled and "ID_KTAU_EST" in filled
    spec = campaign_spec.validate({"missions": 1})
    res = {"index": 0, "seed": 1, "status": "fail", "reason": "", "wall_s": 1.0,
           "report": rep, "rejections": campaign._rejections(rep)}
    row = campaign.result_row(res, campaign_spec.draws(spec, 0))
    assert row["build"] == "float" and row["sensors"] == "all"
    assert row["source"] == "imu_rpm" and row["rejection_reasons"] == "kf: partner_rejected; ktau: uncertain"
    assert set(row) == set(campaign.csv_columns(spec))


@pytest.mark.parametrize("source", ["THRUST", "IMU"])
def test_the_source_of_the_first_result_when_k_f_has_none(tmp_path, source):
    rows = results(random.Random())[6:]   # the inertias alone
    write_log(tmp_path / "fw.lcm", rows, source)
    recs = Logs([tmp_path / "fw.lcm"]).id_results
    assert id_results.estimator_source(recs) == source.lower()
    assert id_results.to_params(recs)["ID_RESULT"] == 14.0
