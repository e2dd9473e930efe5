"""`octo-gcs mission` on the fixed-point build and with the sensors the plant serves.

- `--fixed --in-process` flies octo-sil-fixed (the Q16.16 firmware) and passes every check, the
  report naming the build and the source of its estimates;
- `--sensors thrust,torque,imu,rpm` (every sensor, in any order) is accepted, passed to the plant
  and flies as the default does;
- `--sensors imu` takes the thrust and torque rows away: the mission ends with a report whose
  every estimate is accepted or carries the firmware's reason, and an estimate that rests on rows
  the plant did not serve fails a check naming them. Never a crash.
- `--start-time` and `--shift-origin` reach the plant (its truth log starts at the start time).
"""

import json
import os
import subprocess

from conftest import BUILD, REPO

GCS = REPO / ".venv" / "bin" / "octo-gcs"
ESTIMATES = ("kf", "ktau", "ixx", "iyy", "izz")


def gcs(*args, timeout=300):
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    return subprocess.run([str(GCS), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=env, stdin=subprocess.DEVNULL)


def report(out):
    return json.loads((out / "report.json").read_text())


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


def test_imu_only_ends_with_a_report_and_its_reasons_not_a_crash(tmp_path):
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--sensors", "imu", "--out", out, "--no-plots")
    print(r.stdout[-3000:], r.stderr[-1500:])
    assert "Traceback" not in r.stderr + r.stdout
    assert r.returncode in (0, 1), r.stderr
    rep = report(out)
    assert rep["run"]["sensors"] == ["imu"]
    for k in ESTIMATES:
        row = rep["parameters"][k]
        assert row["accepted"] or row["estimate"] is None or row["reason"], (k, row)
    source = rep["estimator"]["source"]
    served = [c for c in rep["checks"] if c["check"] == "estimates rest on the sensors served"]
    if source == "thrust":   # estimates from rows the plant did not serve: refused, and said
        assert r.returncode == 1 and not rep["pass"]
        assert served and not served[0]["ok"] and "thrust, torque not served" in served[0]["detail"]
        assert not any(rep["parameters"][k]["accepted"] for k in ESTIMATES)
        assert "failed: estimates rest on the sensors served" in r.stdout
    else:
        assert source in ("imu", "imu_rpm") and served and served[0]["ok"]
    assert "Estimated from:" in r.stdout


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

