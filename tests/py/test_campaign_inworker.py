"""The campaign's in-process missions inside the Dask worker's own Python process.

campaign.run_mission flies a real in-process mission (octo-sil) both ways: in a child process
(octo_gcs.mission.child) and through octo_gcs.mission.run in the calling process. octo-sil is deterministic, so both give the same report. A crashing or hanging
octo-sil (a stand-in in a build directory given through OCTO_BUILD) becomes a row with its
reason, as it does through the subprocess.
"""

import json
import os
import random
import subprocess
import sys
import time
from pathlib import Path

from conftest import draw_inertia
from octo_gcs import campaign

REPO = Path(__file__).resolve().parents[2]
BUILD = REPO / "build"
VARIABLE = ("created_utc", "timing")   # the clock's, not the mission's


def job(index, seed, vehicle, faults=None, params=None, timeout=120.0, in_worker=True):
    return {"index": index, "seed": seed, "vehicle": vehicle, "faults": dict(faults or {}), "params": params or {},
            "experiments": [6], "timeout": timeout, "in_process": True, "mission_cmd": None,
            "in_worker": in_worker}


def comparable(rep):
    return {k: v for k, v in rep.items() if k not in VARIABLE}


def test_in_worker_and_subprocess_give_the_same_report():
    rng = random.Random()
    seed = rng.randrange(1, 10_000)
    vehicle = {"kf": rng.uniform(22.0, 34.0), "mass": rng.uniform(1.5, 3.0),
               "inertia": draw_inertia(lambda: [rng.uniform(0.05, 0.08), rng.uniform(0.06, 0.09),
                                                rng.uniform(0.08, 0.12)])}
    faults = {"drop": 0.01} if rng.random() < 0.5 else {}
    params = {"ID_INR_TIME": float(rng.choice([15, 20]))}
    info = f"seed {seed}, vehicle {vehicle}, faults {faults}"
    sub = campaign.run_mission(job(3, seed, vehicle, faults, params, in_worker=False))
    inw = campaign.run_mission(job(3, seed, vehicle, faults, params, in_worker=True))
    assert sub["status"] in ("pass", "fail"), (info, sub["reason"], sub["output_tail"])
    for k in ("index", "seed", "status", "reason", "rejections"):
        assert inw[k] == sub[k], (k, info)
    assert set(inw) == set(sub)
    a, b = sub["report"], inw["report"]
    assert set(a) == set(b) and set(a["timing"]) == set(b["timing"])
    assert comparable(a) == comparable(b), info
    assert a["timing"]["simulated_s"] == b["timing"]["simulated_s"]
    assert a["run"]["plant"] == "octo-sil (in-process, lockstep)" and a["run"]["seed"] == seed
    assert abs(a["truth"]["kf"] - vehicle["kf"]) < 1e-6 * vehicle["kf"]
    # the mission's printed output is the command's too (its last line has the wall time)
    assert [ln for ln in inw["output_tail"] if not ln.startswith(("PASS", "FAIL", "mission in-process",
                                                                    "flight done"))] == \
        [ln for ln in sub["output_tail"] if not ln.startswith(("PASS", "FAIL", "mission in-process",
                                                              "flight done"))]


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


def test_in_worker_octo_sil_crash_is_a_row(tmp_path, monkeypatch):
    monkeypatch.setenv("OCTO_BUILD", str(fake_build(tmp_path, 'echo "octo-sil: boom"; kill -SEGV $$')))
    res = campaign.run_mission(job(1, 11, {}))
    assert res["status"] == "crash", res
    assert res["reason"].startswith("exit status 1: octo-sil exited with status -11"), res["reason"]
    assert "boom" in res["failed_logs"]["octo-sil.log"]
    assert res["report"] is None


def test_in_worker_octo_sil_hang_is_stopped_at_the_timeout(tmp_path, monkeypatch):
    marker = tmp_path / "hung-octo-sil"
    monkeypatch.setenv("OCTO_BUILD", str(fake_build(tmp_path, f'echo "octo-sil: take-off" ; exec sleep 3600 # {marker}')))
    t0 = time.monotonic()
    res = campaign.run_mission(job(2, 12, {}, timeout=3.0))
    assert res["status"] == "timeout", res
    assert res["reason"].startswith("no end after 3 s") and "octo-sil still running after 3 s" in res["reason"]
    assert time.monotonic() - t0 < 60
    # octo-sil was stopped, not left running
    ps = subprocess.run(["pgrep", "-f", str(marker)], capture_output=True, text=True).stdout.split()
    assert ps == []


def test_in_worker_bad_option_is_an_error_row(tmp_path, monkeypatch):
    res = campaign.run_mission(job(4, 13, {"mass": -1.0}))
    assert res["status"] == "crash" and "mass" in res["reason"], res


def test_local_cluster_real_in_process_missions(tmp_path):
    """Two real in-process missions through a local Dask cluster (the worker's own process)."""
    rng = random.Random()
    seed = rng.randrange(1, 10_000)
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"name": "t", "missions": 2, "seed": seed, "plant": "in-process", "timeout": 120,
                                "vehicle": {"kf": {"uniform": [22.0, 34.0]}}}))
    out = tmp_path / "c"
    env = {k: v for k, v in os.environ.items() if k != campaign.MISSION_ENV}
    r = subprocess.run([sys.executable, "-m", "octo_gcs.cli", "campaign", str(spec), "--out", str(out),
                        "--workers", "1"], capture_output=True, text=True, timeout=300, env=env, cwd=REPO)
    assert "in-process (octo-sil)" in r.stderr, r.stderr
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["ran"] == 2, (seed, r.stderr, r.stdout)
    for i in range(2):
        rep = json.loads((out / "missions" / f"{i:04d}" / "report.json").read_text())
        assert rep["run"]["seed"] == seed + i and rep["run"]["plant"] == "octo-sil (in-process, lockstep)"


def test_scratch_writes_complete_files_without_fsync(tmp_path, monkeypatch):
    from octo_gcs import atomicfile
    calls = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (calls.append(fd), real(fd)))
    with atomicfile.scratch():
        atomicfile.atomic_write(tmp_path / "a.txt", "one\n")
    assert (tmp_path / "a.txt").read_text() == "one\n" and calls == []
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]   # no temporary file left
    atomicfile.atomic_write(tmp_path / "a.txt", "two\n")
    assert (tmp_path / "a.txt").read_text() == "two\n" and len(calls) == 2   # the file and its directory
