"""octo-gcs campaign on Dask: a real `dask scheduler` and two `dask worker` processes on loopback,
a local cluster, missions that crash, hang or take their worker down, --resume.

Most campaigns here fly a fake mission (tests/py/campaign_fake_mission.py, given through
OCTO_CAMPAIGN_MISSION) that answers in a fraction of a second; one flies real UDP missions.
"""

import csv
import json
import os
import shlex
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import Process, free_port, wait_until

REPO = Path(__file__).resolve().parents[2]
FAKE = Path(__file__).resolve().parent / "campaign_fake_mission.py"
VENV_BIN = Path(sys.executable).parent


def fake(*opts):
    return " ".join(shlex.quote(str(x)) for x in (sys.executable, FAKE, *opts))


def write_spec(tmp_path, **kw):
    s = {"name": "t", "missions": 6, "seed": 100, "plant": "udp", "timeout": 30,
         "vehicle": {"kf": {"uniform": [20.0, 34.0]}, "inertia": [{"uniform": [0.05, 0.08]}, 0.0762, 0.1014]},
         "faults": {"drop": {"choice": [0.0, 0.02]}}, "params": {"ID_INR_TIME": {"choice": [15, 20]}}}
    s.update(kw)
    p = tmp_path / "spec.json"
    p.write_text(json.dumps(s))
    return p


def run_campaign(spec, out, *opts, mission=None, timeout=170):
    env = dict(os.environ)
    env.pop("OCTO_CAMPAIGN_MISSION", None)
    if mission:
        env["OCTO_CAMPAIGN_MISSION"] = mission
    return subprocess.run([sys.executable, "-m", "octo_gcs.cli", "campaign", str(spec), "--out", str(out), *opts],
                          capture_output=True, text=True, timeout=timeout, env=env, cwd=REPO)


def rows(out):
    with open(out / "results.csv", newline="") as f:
        return list(csv.DictReader(f))


def by_seed(rs):
    return {int(r["seed"]): r for r in rs}


@pytest.fixture
def dask_cluster(tmp_path):
    """`dask scheduler` and two `dask worker` processes on 127.0.0.1 (free ports), stopped at the end."""
    port = free_port(socket.SOCK_STREAM)
    procs = []
    try:
        sched = Process([VENV_BIN / "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                         "--no-dashboard"], tmp_path, "dask-scheduler")
        procs.append(sched)

        def listening():
            with socket.socket() as s:
                return s.connect_ex(("127.0.0.1", port)) == 0
        assert wait_until(listening, timeout=60, step=0.2), sched.stderr()
        addr = f"tcp://127.0.0.1:{port}"
        for k in range(2):
            procs.append(Process([VENV_BIN / "dask", "worker", addr, "--host", "127.0.0.1", "--nworkers", "1",
                                  "--nthreads", "1", "--no-dashboard", "--memory-limit", "0"],
                                 tmp_path, f"dask-worker{k}"))
        assert wait_until(lambda: sched.stderr().count("Register worker") >= 2, timeout=90, step=0.2), \
            sched.stderr()
        yield addr
    finally:
        for p in reversed(procs):
            p.stop(grace=10)


def test_external_cluster_fake_missions_complete_and_resume_adds_nothing(tmp_path, dask_cluster):
    spec = write_spec(tmp_path, missions=8, expect={"k_f_error_pct": 5.0, "silently_wrong": 0})
    out = tmp_path / "c"
    r = run_campaign(spec, out, "--scheduler", dask_cluster, mission=fake("--reject-seed", 103))
    # mission 103 failed its checks (k_f rejected) but ran: every mission ran and expect holds
    assert r.returncode == 0, r.stderr
    rs = rows(out)
    assert sorted(int(x["index"]) for x in rs) == list(range(8))
    assert sorted(int(x["seed"]) for x in rs) == list(range(100, 108))
    m = by_seed(rs)
    assert m[103]["status"] == "fail" and m[103]["kf_accepted"] == "0"
    assert m[103]["rejection_reasons"] == "kf: model"
    assert all(m[s]["source"] == "thrust" for s in m)
    assert all(m[s]["status"] == "pass" for s in m if s != 103)
    # every mission went to a worker of the cluster, not the client
    for i in range(8):
        d = out / "missions" / f"{i:04d}"
        rep = json.loads((d / "report.json").read_text())
        veh = json.loads((d / "vehicle.json").read_text())
        assert rep["run"]["seed"] == 100 + i
        assert veh["kf"] == float(m[100 + i]["vehicle.kf"]) == rep["parameters"]["kf"]["truth"]
        drop = float(m[100 + i]["faults.drop"])
        assert rep["run"]["faults"] == ({"drop": drop} if drop > 0 else {})   # faults reach the plant as data
        assert rep["run"]["params"] == {"ID_INR_TIME": float(m[100 + i]["params.ID_INR_TIME"])}
        assert rep["run"]["plots"] is False
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["in_results"] == 8 and doc["ran"] == 8 and doc["silently_wrong"] == 0
    assert doc["parameters"]["kf"]["rejection_reasons"] == {"model": 1}
    assert doc["sources"] == {"thrust": 8}
    assert doc["parameters"]["kf"]["accepted"] == 7 and doc["parameters"]["ktau"]["accepted"] == 8
    assert doc["throughput"]["workers"] == 2
    md = (out / "campaign.md").read_text()
    assert "SILENTLY WRONG: 0" in md and "Estimated from: thrust rows (8)." in md
    for f in ("error_pct.png", "z_hist.png", "z_qq.png"):
        assert (out / f).stat().st_size > 1000
    # the campaign's missions in the progress line
    assert "8/8 done" in r.stderr
    before = (out / "results.csv").read_text()
    r2 = run_campaign(spec, out, "--scheduler", dask_cluster, "--resume", mission=fake("--reject-seed", 103))
    assert r2.returncode == 0, r2.stderr
    assert (out / "results.csv").read_text() == before
    assert "8 already in" in r2.stderr
    # without --resume an existing campaign is not overwritten
    r3 = run_campaign(spec, out, "--scheduler", dask_cluster, mission=fake())
    assert r3.returncode == 2 and "--resume" in r3.stderr
    assert (out / "results.csv").read_text() == before


def test_local_cluster_crash_and_hang_are_rows_and_the_campaign_goes_on(tmp_path):
    spec = write_spec(tmp_path, missions=6, timeout=6)
    out = tmp_path / "c"
    r = run_campaign(spec, out, "--workers", "2", mission=fake("--crash-seed", 101, "--hang-seed", 104))
    assert r.returncode == 1, r.stderr
    assert "local Dask cluster of 2 worker" in r.stderr
    m = by_seed(rows(out))
    assert sorted(m) == list(range(100, 106))
    assert m[101]["status"] == "crash"
    assert m[101]["reason"] == "exit status 3: fake: octo-fw exited with status 134 (crash on purpose)"
    assert m[104]["status"] == "timeout"
    assert m[104]["reason"].startswith("no end after 6 s") and "take-off never ends" in m[104]["reason"]
    assert all(m[s]["status"] == "pass" for s in (100, 102, 103, 105))
    assert "crash on purpose" in (out / "missions" / "0001" / "mission.log").read_text()
    assert not (out / "missions" / "0001" / "report.json").exists()
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["all_ran"] is False and doc["ok"] is False
    assert {w["seed"] for w in doc["not_ran"]} == {101, 104}
    assert all(f"--seed {w['seed']}" in w["command"] for w in doc["not_ran"])
    assert "PASS" not in r.stdout.splitlines()[-1]
    # the hung mission's process group is gone (no fake mission left running)
    time.sleep(1)
    ps = subprocess.run(["pgrep", "-f", str(out)], capture_output=True, text=True).stdout.split()
    assert ps == []


def test_resume_runs_only_the_missing_missions_and_spec_change_is_refused(tmp_path):
    spec = write_spec(tmp_path, missions=4, expect={"silently_wrong": 0})
    out = tmp_path / "c"
    r = run_campaign(spec, out, "--workers", "1", mission=fake())
    assert r.returncode == 0, r.stderr + r.stdout
    full = rows(out)
    # as if the client had died after two missions, the third row half-written
    lines = (out / "results.csv").read_text().splitlines(keepends=True)
    keep = [lines[0]] + [ln for ln in lines[1:] if ln.split(",")[0] in ("0", "2")]
    (out / "results.csv").write_text("".join(keep) + "3,103,pa")
    r = run_campaign(spec, out, "--workers", "1", "--resume", mission=fake())
    assert r.returncode == 0, r.stderr
    assert "2 already in" in r.stderr and "4/4 done" in r.stderr
    again = rows(out)
    assert sorted(int(x["index"]) for x in again) == [0, 1, 2, 3]
    strip = lambda rs: {x["index"]: {k: v for k, v in x.items() if k not in ("wall_s", "host")} for x in rs}
    assert strip(again) == strip(full)   # the same draws and results, whoever ran them when
    spec.write_text(spec.read_text().replace('"missions": 4', '"missions": 5'))
    r = run_campaign(spec, out, "--workers", "1", "--resume", mission=fake())
    assert r.returncode == 2 and "not the spec" in r.stderr


def test_a_worker_that_dies_is_retried_then_a_row(tmp_path, monkeypatch):
    spec = write_spec(tmp_path, missions=3, retries=1)
    out = tmp_path / "c"
    scratch = tmp_path / "tmp"   # the workers' temp dir (they inherit TMPDIR)
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    r = run_campaign(spec, out, "--workers", "1", mission=fake("--die-seed", 101))
    assert r.returncode == 1, r.stderr
    m = by_seed(rows(out))
    assert sorted(m) == [100, 101, 102]
    assert m[101]["status"] == "lost"
    assert "worker running it died 2 times" in m[101]["reason"]
    assert m[100]["status"] == m[102]["status"] == "pass"
    # the killed workers' mission directories are swept, none is left behind
    assert not list(scratch.glob("octo-campaign-*")), list(scratch.iterdir())


def test_sweep_keeps_live_workers_directories(tmp_path):
    from octo_gcs import campaign
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    mine = tmp_path / f"octo-campaign-{os.getpid()}-0003-abc"
    gone = tmp_path / f"octo-campaign-{dead.pid}-0004-def"
    other = tmp_path / "octo-campaign-notapid"
    for d in (mine, gone, other):
        (d / "out").mkdir(parents=True)
    assert campaign.sweep_stale(tmp_path) == 1
    assert mine.is_dir() and other.is_dir() and not gone.exists()


def test_expect_decides_the_exit_status(tmp_path):
    out = tmp_path / "c"
    spec = write_spec(tmp_path, missions=3, faults={}, expect={"k_f_error_pct": 1e-9})
    r = run_campaign(spec, out, "--workers", "1", mission=fake())
    assert r.returncode == 1 and "k_f_error_pct" in r.stdout and "NOT MET" in r.stdout


def test_in_process_used_when_the_mission_has_it(tmp_path):
    spec = write_spec(tmp_path, missions=2, plant="in-process", faults={})
    out = tmp_path / "c"
    r = run_campaign(spec, out, "--workers", "1", mission=fake("--in-process-help", "--reject-seed", 101))
    assert r.returncode == 0, r.stderr
    assert json.loads((out / "missions/0000/report.json").read_text())["run"]["in_process"] is True
    assert "in-process (octo-sil)" in r.stderr
    # the rejection reason from the report the in-process mission wrote
    assert by_seed(rows(out))[101]["rejection_reasons"] == "kf: model"
    out2 = tmp_path / "c2"
    spec = write_spec(tmp_path, missions=1, plant="in-process", faults={})
    r = run_campaign(spec, out2, "--workers", "1", mission=fake())
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("has no --in-process") == 1
    assert json.loads((out2 / "missions/0000/report.json").read_text())["run"]["in_process"] is False


@pytest.mark.slow
def test_real_missions_on_an_external_cluster(tmp_path, dask_cluster):
    """Two real UDP missions (octo-sim + octo-fw), one with frame loss, on the loopback cluster."""
    spec = write_spec(tmp_path, missions=2, seed=5, plant="udp", timeout=160, params={},
                      vehicle={"kf": {"uniform": [22.0, 34.0]}, "mass": {"uniform": [1.5, 3.0]}},
                      faults={"drop": {"choice": [0.01]}})
    out = tmp_path / "c"
    r = run_campaign(spec, out, "--scheduler", dask_cluster, timeout=175)
    m = by_seed(rows(out))
    assert sorted(m) == [5, 6], r.stderr
    for s, row in m.items():
        assert row["status"] in ("pass", "fail"), row["reason"]
        rep = json.loads((out / "missions" / f"{s - 5:04d}" / "report.json").read_text())
        assert rep["run"]["seed"] == s
        assert abs(rep["truth"]["kf"] - float(row["vehicle.kf"])) < 1e-6 * float(row["vehicle.kf"])
        assert row["kf_estimate"] != ""
    doc = json.loads((out / "campaign.json").read_text())
    assert doc["ran"] == 2
    for w in doc["worst"]:
        assert "--fault drop=0.01" in w["command"]   # the replay keeps the frame loss


def test_a_stopped_client_loses_no_finished_mission(tmp_path):
    """SIGTERM to the client while missions run: every finished mission is in results.csv,
    whole; --resume flies exactly the others."""
    spec = write_spec(tmp_path, missions=30, faults={}, params={})
    out = tmp_path / "c"
    env = dict(os.environ, OCTO_CAMPAIGN_MISSION=fake())
    p = subprocess.Popen([sys.executable, "-m", "octo_gcs.cli", "campaign", str(spec), "--out", str(out),
                          "--workers", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                         cwd=REPO)
    try:
        def some_rows():
            f = out / "results.csv"
            return f.exists() and f.read_text().count("\n") >= 4
        assert wait_until(some_rows, timeout=120, step=0.05)
        p.terminate()
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 143, err
    assert "stopped by SIGTERM" in err and "--resume goes on" in err
    first = rows(out)
    assert 3 <= len(first) < 30
    assert all(r["status"] == "pass" for r in first)
    assert not (out / "campaign.json").exists()
    r = run_campaign(spec, out, "--workers", "2", "--resume", mission=fake())
    assert r.returncode == 0, r.stderr
    assert f"{len(first)} already in" in r.stderr
    allr = rows(out)
    assert sorted(int(x["index"]) for x in allr) == list(range(30))
    assert allr[:len(first)] == first
