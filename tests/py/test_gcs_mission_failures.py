"""`octo-gcs mission` when a phase reaches its limit: it stops, keeps what it has in
DIR/failed-run/ (the logs and a report naming the phase and the reason) and exits
non-zero with the vehicle's reason, never just "octo-sim exited"."""

import json
import os
import random
import re
import subprocess

import pytest

from conftest import BUILD, REPO

GCS = REPO / ".venv" / "bin" / "octo-gcs"


def gcs(*args, timeout=120):
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    return subprocess.run([str(GCS), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=env, stdin=subprocess.DEVNULL)


def failed_report(out):
    d = out / "failed-run"
    rep = json.loads((d / "report.json").read_text())
    md = (d / "report.md").read_text()
    for f in ("truth.lcm", "fw.lcm", "octo-sim.log", "octo-fw.log"):
        assert (d / f).exists(), f
    assert not (out / "report.json").exists()
    return rep, md


@pytest.mark.parametrize("param,phase,reason", [
    ("NAV_TKO_TO=1", "take-off", "Take-off failed: NAV_TKO_TO 1 s"),
    ("NAV_LAND_TO=1", "landing", "Landing failed: NAV_LAND_TO 1 s"),
])
def test_phase_limit_stops_the_mission_with_its_reason(tmp_path, param, phase, reason):
    out = tmp_path / "out"
    r = gcs("mission", "--experiments", "none", "--param", param, "--seed", random.randint(1, 999), "--out", out)
    assert r.returncode != 0, r.stdout
    last = r.stderr.strip().splitlines()
    assert any(f"{phase} failed: {reason}" in line for line in last), r.stderr
    assert "octo-sim exited" not in r.stderr
    rep, md = failed_report(out)
    assert rep["pass"] is False and rep["failed_phase"] == phase and reason in rep["failure"]
    assert f"phase: {phase}" in md and reason in md


def test_impossible_vehicle_take_off_fails_with_reason(tmp_path):
    """Hover throttle 0.99 with MOT_THR_MAX 0.5: the vehicle cannot leave the ground; the
    take-off limit says how far it got and that the hover throttle was not learned."""
    vf = tmp_path / "v.json"
    mass = 2.0
    vf.write_text(json.dumps({"mass": mass, "kf": mass * 9.796 / (8 * 0.99)}))
    out = tmp_path / "out"
    r = gcs("mission", "--vehicle", vf, "--experiments", "none", "--param", "MOT_THR_MAX=0.5",
            "--param", "NAV_TKO_TO=10", "--out", out)
    assert r.returncode != 0
    assert re.search(r"take-off failed: Take-off failed: NAV_TKO_TO 10 s, -?0\.0\d/10\.00 m", r.stderr), r.stderr
    assert "not learned" in r.stderr
    rep, _ = failed_report(out)
    assert rep["failed_phase"] == "take-off"


@pytest.mark.parametrize("param,step,reason", [
    ("NAV_TKO_TO=1", "wait hold", "Take-off failed: NAV_TKO_TO 1 s"),
    ("NAV_LAND_TO=1", "wait disarmed", "Landing failed: NAV_LAND_TO 1 s"),
])
def test_phase_limit_stops_the_in_process_mission_with_its_reason(tmp_path, param, step, reason):
    """octo-sil: the firmware's final FAILED ends the waiting step at once; octo-sil exits
    non-zero naming the step and the firmware's reason, and the logs are kept."""
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--experiments", "none", "--param", param,
            "--seed", random.randint(1, 999), "--out", out)
    assert r.returncode != 0, r.stdout
    assert re.search(rf"step \d+ '{step}' failed at t=[0-9.]+ s: {reason}", r.stderr), r.stderr
    assert "still in mode" not in r.stderr   # not the step's own time limit
    assert (out / "failed-run" / "octo-sil.log").exists()
    assert not (out / "report.json").exists()
