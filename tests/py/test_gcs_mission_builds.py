"""`octo-gcs mission` on the fixed-point build and with the sensors the plant serves.

- `--fixed --in-process` flies octo-sil-fixed (the Q16.16 firmware) and passes every check, the
  report naming the build and the source of its estimates;
- `--sensors thrust,torque,imu,rpm` (every sensor, in any order) is accepted, passed to the plant
  and flies as the default does;
- `--sensors imu` takes the thrust and torque rows away: the firmware refuses the experiment,
  naming the missing rows, and the mission fails with that reason. Never a crash.
- `--start-time` and `--shift-origin` reach the plant (its truth log starts at the start time).
"""

import json
import os
import subprocess

from conftest import BUILD, REPO, read_report, run_gcs

ESTIMATES = ("kf", "ktau", "ixx", "iyy", "izz")


def gcs(*args, timeout=300):
    return run_gcs(*args, timeout=timeout)


report = read_report


def test_fixed_build_flies_the_mission_in_process(tmp_path):
    out = tmp_path / "out"
    r = gcs("mission", "--fixed", "--in-process", "--out", out, "--no-plots")
    print(r.stdout[-3000:], r.stderr[-1500:])
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr
    assert "octo-sil-fixed" in r.stdout.splitlines()[0]
    rep = report(out)
    assert rep["pass"] and rep["run"]["build"] == "fixed"
    assert rep["run"]["plant"] == "octo-sil-fixed (in-process, lockstep)"
    assert all(rep["parameters"][k]["accepted"] for k in ESTIMATES)
    source = rep["estimator"]["source"]
    assert source == "thrust"
    assert "Estimated from: thrust rows (source thrust)" in r.stdout
    md = (out / "report.md").read_text()
    assert "firmware build fixed" in md and "Estimated from: thrust rows (source thrust)." in md


def test_every_sensor_listed_is_accepted_and_flies(tmp_path):
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--sensors", "thrust,torque,imu,rpm", "--out", out, "--no-plots")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr
    rep = report(out)
    assert rep["run"]["sensors"] == ["imu", "rpm", "torque", "thrust"] and rep["run"]["build"] == "float"
    assert all(rep["parameters"][k]["accepted"] for k in ESTIMATES)
    assert [c for c in rep["checks"] if c["check"] == "estimates rest on the sensors served"][0]["ok"]
    assert "sensors served: imu,rpm,torque,thrust" in (out / "report.md").read_text()


def test_imu_only_is_refused_with_its_reason_not_a_crash(tmp_path):
    """Every experiment regresses on the rotors' thrust and torque rows: with the IMU alone the
    firmware refuses it, naming the missing rows, and the mission fails with that reason (its
    logs kept), never with estimates fitted to rows the plant did not serve."""
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--sensors", "imu", "--out", out, "--no-plots")
    print(r.stdout[-3000:], r.stderr[-1500:])
    assert "Traceback" not in r.stderr + r.stdout
    assert r.returncode == 1, r.stderr
    assert "refused: no rotor thrust/torque rows" in r.stdout + r.stderr
    assert not (out / "report.json").exists()
    assert (out / "failed-run").is_dir()


def test_start_time_and_origin_shift_reach_the_plant(tmp_path):
    from octo_gcs.logs import Logs

    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--start-time", "40000", "--shift-origin", "40012",
            "--experiments", "none", "--out", out, "--no-plots")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr
    rep = report(out)
    assert rep["run"]["start_time_s"] == 40000.0 and rep["run"]["shift_origin_s"] == [40012.0]
    truth = Logs([out / "truth.lcm"]).truth
    assert 40000.0 <= truth.t[0] < 40001.0 and truth.t[-1] > 40012.0
    said = (out / "octo-sil.log").read_text()
    assert said.count("Plant moved its local origin") == 1, said[-2000:]

