"""`octo-gcs mission` on the fixed-point build and with the sensors the plant serves.

- `--fixed --in-process` flies octo-sil-fixed (the Q16.16 firmware) and passes every check, the
  report naming the build and the source of its estimates;
- `--sensors thrust,torque,imu,rpm` (every sensor, in any order) is accepted, passed to the plant
  and flies as the default does;
- `--sensors imu` takes the thrust and torque rows away: the firmware identifies from the IMU
  (k_f, I_x, I_y; k_tau / I_z in place of k_tau and I_z) and the report says so; forcing the
  thrust rows (ID_SOURCE 1) then is refused, naming the missing rows, and the mission fails with
  that reason. Never a crash.
- `--start-time` and `--shift-origin` reach the plant (its truth log starts at the start time).
"""

import json
import os
import random
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


def test_imu_only_flies_and_identifies_from_the_imu(tmp_path):
    """With the IMU alone (no thrust or torque rows) the firmware's auto source takes the IMU:
    the mission passes, k_f, I_x and I_y are accepted within max(3 sd, tolerance) of the truth,
    k_tau and I_z are reported as not identifiable (no value), their ratio is identified with its
    sd, each rotor's effectiveness is not identified, and the validation names the collective
    force it compares."""
    seed = random.randrange(1, 10_000)
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--sensors", "imu", "--seed", seed, "--out", out, "--no-plots")
    info = f"seed {seed}: " + r.stdout[-3000:] + r.stderr[-1500:]
    assert "Traceback" not in r.stderr + r.stdout, info
    assert r.returncode == 0, info
    rep = report(out)
    assert rep["pass"] and rep["run"]["sensors"] == ["imu"], info
    assert rep["estimator"]["source"] == "imu" and rep["estimator"]["ID_SRC_USED"] == 2.0, info
    assert "Estimated from: IMU (source imu)" in r.stdout
    tol = {"kf": 0.3, "ixx": 2.0, "iyy": 2.0}
    for key, pct in tol.items():
        row = rep["parameters"][key]
        assert row["accepted"] and row["source"] == "imu", (key, row, info)
        err = abs(row["estimate"] - row["truth"])
        assert err <= max(3 * row["sd"], pct / 100 * row["truth"]), (key, row, info)
    for key in ("ktau", "izz"):
        row = rep["parameters"][key]
        assert row["identifiable"] is False and row["estimate"] is None and not row["accepted"], (key, row)
        assert row["reason"] == "not_identifiable" and row["vehicle_value"] == row["nominal"], (key, row)
    x = rep["ktau_over_izz"]
    assert x["accepted"] and x["sd"] > 0 and x["source"] == "imu", x
    assert abs(x["estimate"] - x["truth"]) <= max(3 * x["sd"], 0.02 * x["truth"]), (x, info)
    checks = {c["check"]: c for c in rep["checks"]}
    assert checks["k_tau/I_z vs truth"]["ok"] and checks["I_z not identifiable from the gyro alone"]["ok"]
    assert "k_tau vs truth" not in checks and "k_tau estimated" not in checks
    assert "not identifiable from the gyro alone" in r.stdout and "k_tau/I_z [1/s^2]" in r.stdout
    assert r.stdout.count("not identified (source imu)") == 8
    assert "measured collective force m g a_z vs the modelled thrusts' sum" in r.stdout
    assert "commanded vs measured f_1" not in r.stdout
    md = (out / "report.md").read_text()
    assert "Estimated from: IMU (source imu)." in md and "| k_tau/I_z [1/s^2] |" in md


def test_thrust_source_forced_without_its_rows_is_refused_with_its_reason(tmp_path):
    """ID_SOURCE 1 (thrust rows) with the IMU alone: the firmware refuses the experiment, naming
    the missing rows, and the mission fails with that reason (its logs kept), never with
    estimates fitted to rows the plant did not serve."""
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--sensors", "imu", "--param", "ID_SOURCE=1", "--out", out, "--no-plots")
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

