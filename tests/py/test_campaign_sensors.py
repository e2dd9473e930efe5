"""Campaigns that fly the same vehicles with several sensor sets (host_tools/campaigns/sensors.json):
the spec's `sensors` as a list of sets flies every vehicle once with each, with the vehicle's
draws and seed; campaign.md puts the sources side by side, each against the truth and against
the same vehicle's thrust-row estimate. A real campaign over a tiny sample of sensors.json (its
first vehicles) checks the comparison against results.csv."""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from octo_gcs import campaign, campaign_spec as cs

REPO = Path(__file__).resolve().parents[2]
SENSORS = REPO / "host_tools" / "campaigns" / "sensors.json"
ALL = ["imu", "rpm", "torque", "thrust"]


def test_sensor_sets_fly_every_vehicle_with_each_set(tmp_path):
    s = cs.validate(json.loads(SENSORS.read_text()))
    cs.check_all_draws(s)
    sets = cs.sensor_sets(s)
    assert sets == [ALL, ["imu"]] and cs.flights(s) == 2 * s["missions"]
    for v in range(s["missions"]):
        a, b = (cs.mission_inputs(s, 2 * v + k) for k in (0, 1))
        assert a[0] == b[0] == s["seed"] + v            # the vehicle's seed
        assert a[2] == b[2] and a[3] == b[3] and a[4] == b[4]   # its vehicle file, faults, parameters
        da, db = dict(a[1]), dict(b[1])
        assert (da.pop("sensors"), db.pop("sensors")) == (",".join(ALL), "imu")
        assert da == db and da["vehicle"] == v
        assert cs.words(s, 2 * v)["sensors"] == ALL and cs.words(s, 2 * v + 1)["sensors"] == ["imu"]
    # the vehicles differ, and are those of the same spec without sets (one flight each)
    plain = dict(s, sensors="imu")
    assert cs.mission_inputs(plain, 3)[2] == cs.mission_inputs(s, 6)[2] != cs.mission_inputs(s, 4)[2]
    cols = campaign.csv_columns(s)
    assert cols[cols.index("host") + 1:cols.index("host") + 4] == ["build", "sensors", "vehicle"]
    assert "vehicle" not in campaign.csv_columns(plain)
    jobs, _inputs = campaign._jobs(s, range(4), True, None)
    assert [campaign.mission_options(j, tmp_path).sensors for j in jobs] == [ALL, ["imu"], ALL, ["imu"]]
    assert [j["seed"] for j in jobs] == [s["seed"], s["seed"], s["seed"] + 1, s["seed"] + 1]


def test_one_set_is_a_campaign_of_one_flight_per_vehicle():
    s = cs.validate({"missions": 3, "sensors": [["imu"]]})
    assert cs.flights(s) == 3 and [cs.words(s, i)["sensors"] for i in range(3)] == [["imu"]] * 3


def rows_of(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_sources_side_by_side_on_a_sample_of_the_sensors_campaign(tmp_path):
    spec = json.loads(SENSORS.read_text())
    spec["missions"] = 2          # the first two vehicles, each with thrust rows and with the IMU
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / "c"
    env = {k: v for k, v in os.environ.items() if k != campaign.MISSION_ENV}
    r = subprocess.run([sys.executable, "-m", "octo_gcs.cli", "campaign", str(path), "--out", str(out),
                        "--workers", "1"], capture_output=True, text=True, timeout=240, env=env, cwd=REPO)
    assert "4 missions (2 vehicles x 2 sensor sets)" in r.stderr, r.stderr
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["missions"] == 4 and doc["ran"] == 4, (r.stderr[-2000:], r.stdout)
    rows = rows_of(out / "results.csv")
    by = {(int(x["vehicle"]), x["source"]): x for x in rows}
    assert set(by) == {(v, src) for v in (0, 1) for src in ("thrust", "imu")}
    for v in (0, 1):
        t, i = by[(v, "thrust")], by[(v, "imu")]
        assert t["seed"] == i["seed"] and t["sensors"] == ",".join(ALL) and i["sensors"] == "imu"
        assert t["kf_truth"] == i["kf_truth"] and t["ixx_truth"] == i["ixx_truth"]
        assert i["not_identifiable"] == "ktau izz" and i["ktau_estimate"] == i["izz_estimate"] == ""
        assert i["ktiz_estimate"] != "" and t["ktiz_estimate"] == "" and t["not_identifiable"] == ""
    bs = doc["by_source"]
    assert bs["sources"] == ["thrust", "imu"] and bs["reference"] == "thrust" and bs["vehicles"] == 2
    got = {(x["parameter"], x["source"]): x for x in bs["rows"]}
    assert got[("ktau", "imu")]["not_identifiable"] == 2 and got[("ktau", "imu")]["estimated"] == 0
    assert got[("izz", "imu")]["not_identifiable"] == 2 and got[("kf", "thrust")]["vs_reference"] is None
    # each IMU estimate against the truth and the thrust rows' of the same vehicle, from results.csv
    for q in ("kf", "ixx", "iyy", "ktiz"):
        x = got[(q, "imu")]
        diffs, errs = [], []
        for v in (0, 1):
            i, t = by[(v, "imu")], by[(v, "thrust")]
            if i[f"{q}_accepted"] != "1":
                continue
            est, tru = float(i[f"{q}_estimate"]), float(i[f"{q}_truth"])
            errs.append(100 * (est - tru) / tru)
            if q == "ktiz":
                ok = t["ktau_accepted"] == t["izz_accepted"] == "1"
                ref = float(t["ktau_estimate"]) / float(t["izz_estimate"]) if ok else None
            else:
                ref = float(t[f"{q}_estimate"]) if t[f"{q}_accepted"] == "1" else None
            if ref is not None:
                diffs.append(100 * (est - ref) / ref)
        assert x["accepted"] == len(errs) and x["vs_reference"]["pairs"] == len(diffs), (q, x)
        if errs:
            assert x["error_pct"]["max_abs"] == pytest.approx(max(map(abs, errs)))
        if diffs:
            assert x["vs_reference"]["diff_pct"]["max_abs"] == pytest.approx(max(map(abs, diffs)))
    md = (out / "campaign.md").read_text()
    assert "## Sources side by side (the same vehicles)" in md
    assert "| k_tau | IMU | not identifiable (2) |" in md and "| k_tau/I_z | IMU | " in md
    assert "| k_f | thrust rows | 2 |" in md and "| reference |" in md
