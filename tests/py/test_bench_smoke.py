"""make bench's harnesses run (tiny configurations; no timing is asserted here).

The figures themselves come from `make bench` (tests/bench/bench.py); this only proves
that each harness builds, runs and says what bench.py parses. Needs `make bench-tools`
(part of `make`)."""

import json
import os
import re
import shutil
import subprocess
import sys

import pytest

from conftest import BUILD, REPO

BB = BUILD / "bench"
sys.path.insert(0, str(REPO / "tests" / "bench"))


def tool(name):
    p = BB / name
    if not p.exists():
        pytest.fail(f"{p} is not built: run `make bench-tools`")
    return str(p)


def run_json(*argv):
    out = subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_pingpong_exchanges_every_datagram():
    r = run_json(tool("pingpong"), "pp", 300, 221, 8, 509)
    assert r["frames"] == 300 and r["frames_per_s"] > 0


def test_physics_runs():
    r = run_json(tool("bench-physics"), 2)
    assert r["frames"] == 180 and r["rk4_steps"] == 6 * 180 and r["rk4_steps_per_s"] > 0


def test_peakrss_reports_the_child_and_passes_its_status():
    out = subprocess.run([tool("peakrss"), tool("bench-physics"), "1"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and json.loads(out.stdout)["frames"] == 90
    m = re.search(r"^peakrss: peak_rss_kb (\d+) cpu_s ([0-9.]+) status 0$", out.stderr, re.M)
    assert m and int(m.group(1)) > 0, out.stderr
    bad = subprocess.run([tool("peakrss"), tool("bench-physics") + "-no-such"], capture_output=True, text=True,
                         timeout=60)
    assert bad.returncode == 127 and "cannot run" in bad.stderr


def test_alloc_reports_both_modes():
    r = run_json(tool("bench-alloc"), 500, 3)
    assert r["attainable"] + r["unattainable"] + r["boundary_band"] == 500
    assert r["priority"]["exact_attainable"] == r["attainable"]   # the allocator's contract
    assert r["clip"]["exact_attainable"] <= r["attainable"]


def test_estim_plain_bias_matches_closed_form():
    r = run_json(tool("bench-estim"), 40, 2)
    assert r["runs"] == 40
    for key in ("t5", "t10"):
        assert set(r[key]) >= {"own", "plain"}
        assert r[key]["plain"]["bias_pct"] == pytest.approx(r["plain_bias_closed_form_pct"], abs=1.0)


def test_step_harness_reaches_hold_and_measures():
    out = subprocess.run([tool("bench-step-quick")], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    kv = dict(re.findall(r"^step: (\S+) (.*)$", out.stdout, re.M))
    assert kv.get("done") is not None or "step: done" in out.stdout
    assert int(kv["hold_steps"]) > 0, out.stdout


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind not installed")
def test_callgrind_parse_finds_the_step(tmp_path):
    import bench
    cg = tmp_path / "cg.out"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={cg}", "--compress-strings=no",
                    "--compress-pos=no", tool("bench-step-quick")], capture_output=True, timeout=120, check=True)
    got = bench.parse_callgrind(cg, ["bench_hold_step", "bench_alloc_worst"])
    assert got["bench_hold_step"]["calls"] > 0 and got["bench_hold_step"]["ir"] > 1000
    assert got["bench_alloc_worst"]["calls"] == 1


def test_bench_driver_quick(tmp_path):
    out_json = tmp_path / "bench.json"
    argv = [sys.executable, str(REPO / "tests/bench/bench.py"), "--quick", "--repeats", "1",
            "--only", "alloc,estim,sim", "--out", str(out_json)]
    out = subprocess.run(argv, capture_output=True, text=True, timeout=120, cwd=REPO)
    assert out.returncode == 0, out.stdout + out.stderr
    doc = json.loads(out_json.read_text())
    assert not doc["errors"]
    assert {r["item"] for r in doc["rows"]} == {4, 5, 6}
    assert (tmp_path / "bench.md").read_text().count("\n| ") >= 5
