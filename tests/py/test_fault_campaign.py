"""The fault campaign (host_tools/campaigns/faults.json) on a small sample, and what it relies on.

A derived spec flies 6 of its missions through a local Dask cluster with the real octo-sil; half
of them (drawn) get a rotor failure and half a stuck rotor-speed report, on top of the spec's link
faults and IMU spikes. No mission may crash, hang or be lost, no accepted estimate may be silently
wrong, and every mission that did not pass has its reason. A rotor failure that stops the
experiment is an "aborted" row naming the rotor, not a crash. The spec's and the vehicle file's
checks of the plant's events name the key.
"""

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from octo_gcs import campaign, campaign_spec, vehiclefile
from octo_gcs.campaign_spec import SpecError

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "build"
SPEC = REPO / "host_tools" / "campaigns" / "faults.json"
MISSIONS = 6


def derived_spec(tmp_path, missions=MISSIONS):
    spec = json.loads(SPEC.read_text())
    spec["missions"] = missions
    spec["timeout"] = 120
    spec["vehicle"]["rotor_failure"]["probability"] = 0.5
    spec["vehicle"]["stuck_rpm"]["probability"] = 0.5
    path = tmp_path / "faults.json"
    path.write_text(json.dumps(spec))
    return path


def test_fault_spec_is_valid_and_draws_every_fault():
    spec = campaign_spec.load(SPEC)
    assert spec["missions"] == 1000 and spec["experiments"] == [6] and spec["plant"] == "in-process"
    for name in ("drop", "burst", "reorder", "duplicate", "delay_frames", "imu_spike"):
        assert name in spec["faults"], name
    on = {"rotor_failure": 0, "stuck_rpm": 0}
    n = 200
    for i in range(n):
        _seed, d, vehicle, faults, _params = campaign_spec.mission_inputs(spec, i)
        for k in on:
            assert (k in vehicle) == (d[f"vehicle.{k}.on"] == 1)
            if k in vehicle:
                on[k] += 1
                assert vehicle[k]["rotor"] in range(1, 9) and 5.0 <= vehicle[k]["at_s"] <= 75.0
        assert set(faults) <= set(campaign_spec.FAULTS)
        vehiclefile.parse(json.dumps(vehicle))  # what octo-gcs reads of the file
    # 30 % and 20 %: binomial sd over 200 draws 3.2 and 2.8 points; 4 sd
    assert abs(on["rotor_failure"] / n - 0.3) < 0.13 and abs(on["stuck_rpm"] / n - 0.2) < 0.12, on


@pytest.mark.parametrize(
    "vehicle, key",
    [
        ({"rotor_failure": {"rotor": 9, "at_s": 1}}, "vehicle.rotor_failure.rotor"),
        ({"rotor_failure": {"rotor": {"choice": [1, 2]}, "at_s": 1, "scale": 1.5}}, "vehicle.rotor_failure.scale"),
        ({"rotor_failure": {"rotor": 1}}, "vehicle.rotor_failure.at_s"),
        ({"rotor_failure": {"rotor": 1, "at_s": 1, "probability": 2}}, "vehicle.rotor_failure.probability"),
        ({"rotor_failure": {"rotor": 1, "at_s": 1, "when": 2}}, "vehicle.rotor_failure: unknown key 'when'"),
        ({"rotor_failure": [{"rotor": 1, "at_s": 1}]}, "vehicle.rotor_failure: must be one object"),
        ({"stuck_rpm": {"rotor": 1, "at_s": -1}}, "vehicle.stuck_rpm.at_s"),
        ({"stuck_rpm": {"rotor": 1.5, "at_s": 1}}, "vehicle.stuck_rpm.rotor"),
        ({"imu_spike": {"prob": 1.5}}, "vehicle.imu_spike.prob"),
    ],
)
def test_spec_event_errors_name_the_key(vehicle, key):
    with pytest.raises(SpecError) as e:
        campaign_spec.validate({"missions": 1, "vehicle": vehicle})
    assert str(e.value).startswith(key), str(e.value)


@pytest.mark.parametrize(
    "raw, key",
    [
        ({"rotor_failure": {"rotor": 0, "at_s": 1}}, "'rotor_failure.rotor'"),
        ({"rotor_failure": [{"rotor": 2, "at_s": 1, "scale": 2}]}, "'rotor_failure.scale'"),
        ({"rotor_failure": {"at_s": 1}}, "'rotor_failure' needs 'rotor'"),
        ({"stuck_rpm": {"rotor": 2}}, "'stuck_rpm' needs 'at_s'"),
        ({"stuck_rpm": {"rotor": 2, "at_s": 1, "scale": 0}}, "'stuck_rpm.scale'"),
        ({"imu_spike": {"gyro": 0}}, "'imu_spike.gyro'"),
        ({"imu_spike": {"size": 1}}, "'imu_spike.size'"),
    ],
)
def test_vehicle_file_event_errors_name_the_key(raw, key):
    with pytest.raises(vehiclefile.VehicleFileError) as e:
        vehiclefile.parse(json.dumps(raw))
    assert key in str(e.value), str(e.value)


def test_vehicle_file_accepts_the_events():
    v = vehiclefile.parse(
        json.dumps(
            {
                "rotor_failure": [{"rotor": 3, "at_s": 40.0}, {"rotor": 6, "at_s": 55, "scale": 0.5}],
                "stuck_rpm": {"rotor": 2, "at_s": 10},
                "imu_spike": {"prob": 0.01, "gyro": 3, "accel": 30},
            }
        )
    )
    assert v["rotor_failure"][1]["scale"] == 0.5 and v["stuck_rpm"]["rotor"] == 2


def fake_build(tmp_path, body):
    """A build directory whose octo-sil is a shell script `body`; octo-sim and octo-fw the real ones."""
    d = tmp_path / "build"
    d.mkdir()
    for name in ("octo-sim", "octo-fw"):
        (d / name).symlink_to(BUILD / name)
    sil = d / "octo-sil"
    sil.write_text("#!/bin/sh\n" + body + "\n")
    sil.chmod(0o755)
    return d


def job(vehicle):
    return {"index": 0, "seed": 1, "vehicle": vehicle, "faults": {}, "params": {}, "experiments": [6],
            "timeout": 60.0, "in_process": True, "mission_cmd": None, "in_worker": True}


def test_a_step_the_vehicle_ends_is_aborted_and_a_signal_is_a_crash(tmp_path, monkeypatch):
    line = ("octo-sil: script step 8 'wait experiment' failed at t=40.02 s: experiment ended FAILED "
            "(Rotor 3 failed (effectiveness 0.00, from its thrust): holding on the others, then landing)")
    monkeypatch.setenv("OCTO_BUILD", str(fake_build(tmp_path, f'echo "{line}"; exit 1')))
    res = campaign.run_mission(job({}))
    assert res["status"] == "aborted", res
    assert res["reason"].startswith("script step 8 'wait experiment' failed at t=40.02 s") and "Rotor 3" in res["reason"]
    # the same line from an octo-sil that then dies of a signal: a crash
    (tmp_path / "build" / "octo-sil").write_text(f'#!/bin/sh\necho "{line}"; kill -SEGV $$\n')
    res = campaign.run_mission(job({}))
    assert res["status"] == "crash", res


def test_a_sample_of_the_fault_campaign(tmp_path):
    """6 real missions of the fault spec: no crash, no silently wrong value, every failure with its reason."""
    out = tmp_path / "c"
    env = {k: v for k, v in os.environ.items() if k != campaign.MISSION_ENV}
    r = subprocess.run(
        [sys.executable, "-m", "octo_gcs.cli", "campaign", str(derived_spec(tmp_path)), "--out", str(out),
         "--workers", "1"],
        capture_output=True, text=True, timeout=300, env=env, cwd=REPO,
    )
    assert (out / "campaign.json").exists(), (r.stdout, r.stderr)
    doc = json.loads((out / "campaign.json").read_text())
    with open(out / "results.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == MISSIONS
    bad = [(r["index"], r["status"], r["reason"]) for r in rows if r["status"] not in ("pass", "fail", "aborted")]
    assert not bad, bad
    assert doc["silently_wrong"] == 0, doc["silently_wrong_list"]
    for row in rows:
        if row["status"] != "pass":
            assert row["reason"].strip(), row
        if row["status"] == "aborted":
            assert row["reason"].startswith("script step "), row["reason"]
        vehicle = json.loads((out / "missions" / f"{int(row['index']):04d}" / "vehicle.json").read_text())
        for k in ("rotor_failure", "stuck_rpm"):
            assert (k in vehicle) == (row[f"vehicle.{k}.on"] == "1"), (k, row["index"])
    assert any(row["vehicle.rotor_failure.on"] == "1" for row in rows)
    assert any(row["vehicle.stuck_rpm.on"] == "1" for row in rows)


def test_inertia_octo_sim_would_refuse_is_a_spec_error():
    spec = campaign_spec.validate(
        {"missions": 50, "vehicle": {"inertia": [0.03768, {"uniform": [0.04572, 0.10668]}, 0.06084]}}
    )
    with pytest.raises(SpecError) as e:
        campaign_spec.check_all_draws(spec)
    assert str(e.value).startswith("vehicle.inertia[1]: mission "), str(e.value)
