"""END-TO-END: `octo-gcs mission` on a randomised vehicle (octo-sim + octo-fw in
lockstep, take-off, experiment 6, landing), then every output file and the accuracy
in report.json: k_f and k_tau within 0.3 %, inertia within 2 % of the truth.

The vehicle is drawn anew each run (each of mass, arm length, k_f, k_tau, Ix, Iy, Iz
within +/-30 % of the paper's); the test prints it, and OCTO_E2E_SEED=N repeats a draw.
Also: Ctrl-C during a mission stops both programs and leaves no half report.
"""

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import BUILD, REPO, draw_inertia
from ident_helpers import false_alarm, fw_said

sys.path.insert(0, str(BUILD / "gen" / "python"))

from octo_gcs import id_results, paramfile  # noqa: E402
from octo_gcs.logs import Logs  # noqa: E402

GCS = REPO / ".venv" / "bin" / "octo-gcs"
PAPER = {"mass": 2.132, "arm_length": 0.35, "kf": 28.0269, "ktau": 0.3869}
INERTIA = (0.0628, 0.0762, 0.1014)
OUTPUTS = ["report.md", "report.json", "params.parm", "truth.lcm", "fw.lcm", "octo-sim.log", "octo-fw.log",
           "fig5_excitation.png", "fig6_validation.png", "fig7_rates.png", "convergence.png"]


def random_vehicle(seed):
    rng = random.Random(seed)
    v = {k: round(x * rng.uniform(0.7, 1.3), 6) for k, x in PAPER.items()}
    v["inertia"] = draw_inertia(lambda: [round(x * rng.uniform(0.7, 1.3), 6) for x in INERTIA])
    return v


def gcs(*args, timeout=90):
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    return subprocess.run([str(GCS), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=env, stdin=subprocess.DEVNULL)


def our_processes(marker):
    """octo-sim / octo-fw processes whose command line mentions `marker` (a test's own
    directory): (pid, command line)."""
    found = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                argv = Path(f"/proc/{d}/cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            cmd = b" ".join(argv).decode(errors="replace")
            if argv and os.path.basename(argv[0]).decode(errors="replace") in ("octo-sim", "octo-fw") \
                    and marker in cmd:
                found.append((int(d), cmd))
    return found


@pytest.mark.slow
def test_e2e_mission_on_a_random_vehicle(tmp_path):
    seed = int(os.environ.get("OCTO_E2E_SEED", random.SystemRandom().randrange(1, 1_000_000)))
    veh = random_vehicle(seed)
    print(f"OCTO_E2E_SEED={seed}: vehicle {json.dumps(veh)}")
    vfile = tmp_path / "vehicle.json"
    vfile.write_text(json.dumps(veh))
    run_seed = seed % 1000 + 1
    for attempt in (1, 2):
        out = tmp_path / f"out{attempt}"
        t0 = time.monotonic()
        r = gcs("mission", "--vehicle", vfile, "--seed", run_seed, "--out", out)
        wall = time.monotonic() - t0
        log = out / "octo-fw.log"
        said = fw_said(log.read_text()) if log.exists() else []
        if attempt == 2 or r.returncode == 0 or not false_alarm(said):
            break
        # the whiteness test's known false rejections (ident_helpers.false_alarm): the same
        # vehicle once more, with other noise, as a user would fly it again
        print(f"whiteness rejected the motor model (seed {run_seed}): flown again")
        run_seed += 1000
    print(r.stdout[-3000:], r.stderr[-2000:])
    print(f"mission wall time {wall:.1f} s")
    assert "Traceback" not in r.stderr

    # every output file, complete, nothing temporary left
    names = sorted(os.listdir(out))
    assert sorted(OUTPUTS) == names, names
    for n in OUTPUTS:
        assert (out / n).stat().st_size > 0, n
    for n in OUTPUTS:
        if n.endswith(".png"):
            data = (out / n).read_bytes()
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20000, n
    rep = json.loads((out / "report.json").read_text())
    md = (out / "report.md").read_text()
    assert "| k_f [N] | 28.0269 |" in md and "lag-aware" in md
    params = paramfile.load(out / "params.parm")
    assert params["VEH_MASS"] == pytest.approx(veh["mass"], rel=1e-6)      # the bench values were set
    assert params["VEH_ARM_L"] == pytest.approx(veh["arm_length"], rel=1e-6)
    logs = Logs([out / "truth.lcm", out / "fw.lcm"])
    assert len(logs.truth) > 1000 and len(logs.fw) > 1000
    assert logs.truth.kf[0] == pytest.approx(veh["kf"]) and logs.truth.inertia[0, 2] == pytest.approx(veh["inertia"][2])
    assert "stopped at" in (out / "octo-sim.log").read_text()             # stopped cleanly
    assert not our_processes(str(tmp_path)), "octo-sim/octo-fw still running"

    # the report: truth, estimates, standard deviations, validation, model fit
    truth = {"kf": veh["kf"], "ktau": veh["ktau"], "ixx": veh["inertia"][0], "iyy": veh["inertia"][1],
             "izz": veh["inertia"][2]}
    assert rep["truth"] == pytest.approx(truth)
    assert rep["run"]["seed"] == run_seed
    for key, row in rep["parameters"].items():
        assert row["estimate"] is not None and row["sd"] > 0, (key, row)
        assert row["error_pct"] == pytest.approx(100 * (row["estimate"] - truth[key]) / truth[key], abs=1e-3)
        assert params[{"kf": "VEH_KF", "ktau": "VEH_KTAU", "ixx": "VEH_IXX", "iyy": "VEH_IYY",
                       "izz": "VEH_IZZ"}[key]] == pytest.approx(row["estimate"], abs=1e-6), key  # %f: 6 decimals
    assert rep["parameters"]["kf"]["plain"] is not None
    assert len(rep["validation"]["from_log"]) == 2
    assert {m["experiment"] for m in rep["model_fit"]} == {"ixx", "iyy", "izz"}
    for m in rep["model_fit"]:
        ax = {"ixx": "wx", "iyy": "wy", "izz": "wz"}[m["experiment"]]
        assert m["fit_pct"][ax] > 90, m

    # the accuracy asked of the whole chain
    errs = {k: row["error_pct"] for k, row in rep["parameters"].items()}
    print("errors %:", errs)
    # k_f is the thrust at full throttle: the firmware estimates the thrust curve too, so k_f
    # is an extrapolation from hover throttles; within 0.3 % or 4 of its reported sds
    for k in ("kf", "ktau"):
        row = rep["parameters"][k]
        lim = max(0.3, 400.0 * row["sd"] / truth[k])
        assert abs(errs[k]) <= lim, (k, errs, lim)
    assert all(abs(errs[k]) <= 2.0 for k in ("ixx", "iyy", "izz")), errs
    failed = [c for c in rep["checks"] if not c["ok"] and not c["warning_only"]]
    assert rep["pass"] and not failed, failed

    # the firmware's results as data (OCTO_ID_RESULT over MAVLink, and the same records in
    # fw.lcm): each estimate's verdict and the measurements it rests on
    sources = ("thrust", "imu", "imu_rpm", "imu_rpm_torque")
    assert rep["estimator"]["source"] in sources, rep["estimator"]
    for key, row in rep["parameters"].items():
        assert row["source"] in sources and (row["reason"] == "ok") == row["accepted"], (key, row)
    assert rep["results_from_records"] == []   # every value is a parameter too
    assert {r["param"] for r in rep["id_results"]} >= {"kf", "ktau", "ixx", "iyy", "izz"}
    logged = {(d["param"], d["rotor"]): d for d in map(id_results.describe, logs.id_results)}
    for res in rep["id_results"]:
        assert logged[(res["param"], res["rotor"])]["accepted"] == res["accepted"], res
    assert r.returncode == 0
    assert wall < 45, f"mission took {wall:.1f} s"


def test_ctrl_c_stops_both_programs_and_leaves_no_half_report(tmp_path):
    out = tmp_path / "out"
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    p = subprocess.Popen([str(GCS), "mission", "--out", str(out), "--realtime"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=env, stdin=subprocess.DEVNULL)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and len(our_processes(str(out))) < 2:
        time.sleep(0.05)
    assert len(our_processes(str(out))) >= 2, "octo-sim and octo-fw did not start"
    time.sleep(1.0)                       # real time: somewhere in the take-off
    p.send_signal(signal.SIGINT)
    so, se = p.communicate(timeout=20)
    assert p.returncode == 130, (so, se)
    assert "interrupted" in se and "Traceback" not in se
    time.sleep(0.2)
    assert not our_processes(str(out)), "octo-sim/octo-fw still running after Ctrl-C"
    assert not (out / "report.md").exists() and not (out / "report.json").exists()
    assert not [n for n in os.listdir(out) if n.startswith(".tmp")]
    assert (out / "failed-run" / "fw.lcm").exists()
