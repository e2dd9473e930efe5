"""The mission report compares every estimate with the truth at the same simulated time:
k_f drifting at a random rate, the rotor coefficients against the truth log's mean over the
rotor experiment (not the vehicle file's value, nor another moment), and the k_f the firmware
tracked through HOLD and the experiments against the truth log at each sample's time, its
drift within 0.3 % of the truth's.

The tracked k_f is judged as the report judges it: a sample fails when it lies beyond the
identified k_f's limit (0.3 % or 4 of the identified sd) and also beyond 4 of the tracked
k_f's own published sd (KFT_SD, absolute: the identified model's error and the tracking's).
The identified limit alone leaves out the tracking's own error (the tracked sd here is about
0.25 %, nearly twice the identified k_f's 0.11-0.15 %): an identified k_f 2-3 of its sds off,
plus the tracking's error, put a sample beyond that limit on 17 of 209 draws (8 %; seeds
600000-600149 and 59 random ones), each of those samples within 3.5 of its own sd; by the
report's rule none of the 209 fails (largest |z| of a tracked sample 3.43). The seed is new
each run and printed; OCTO_SAME_TIME_SEED=N repeats a draw."""

import json
import os
import random
import subprocess

import numpy as np
import pytest

from conftest import BUILD, REPO
from octo_gcs.logs import Logs

GCS = REPO / ".venv" / "bin" / "octo-gcs"


def test_report_compares_with_the_truth_at_the_same_time(tmp_path):
    seed = int(os.environ.get("OCTO_SAME_TIME_SEED", random.SystemRandom().randrange(1, 10**6)))
    rng = random.Random(seed)
    drift = rng.uniform(-0.03, -0.015)   # over the compared ~28 s: more than the 0.3 % tolerance
    kf = 28.0269 * rng.uniform(0.8, 1.2)
    vf = tmp_path / "v.json"
    vf.write_text(json.dumps({"kf": kf, "ktau": 0.3869 * kf / 28.0269, "kf_drift_per_min": drift}))
    out = tmp_path / "out"
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    r = subprocess.run([str(GCS), "mission", "--in-process", "--vehicle", str(vf), "--seed", str(seed),
                        "--out", str(out), "--no-plots"], capture_output=True, text=True, timeout=300, env=env)
    print(f"seed {seed}, k_f {kf:.4f} N drifting {100 * drift:+.2f} %/min")
    assert r.returncode == 0, r.stdout + r.stderr
    rep = json.loads((out / "report.json").read_text())
    logs = Logs([out / "truth.lcm", out / "fw.lcm"])
    tr = logs.truth
    # the rotor coefficients: the truth is the log's mean over the rotor experiment
    t0, t1 = rep["truth_window_s"]["kf"]
    sel = (tr.t >= t0) & (tr.t <= t1)
    assert t1 - t0 > 5 and rep["truth"]["kf"] == pytest.approx(float(tr.kf[sel].mean()), rel=1e-6)
    row = rep["parameters"]["kf"]
    print(f"k_f {row['estimate']} vs truth {row['truth']} over {t0}-{t1} s: {row['error_pct']:+.3f} %")
    # within the mission's own limit (0.3 %, or 4 sd: with the curve estimated k_f is an
    # extrapolation to full throttle), and the truth it uses is not the vehicle file's
    assert abs(row["error_pct"]) < max(0.3, 4 * row["sd_pct"]) and row["truth"] != pytest.approx(kf, rel=1e-3)
    # the tracked k_f: each sample's truth is the truth log's at the sample's time
    # (after identification the tracker's k_f carries the identified curve's error, as the
    # identified k_f does: the same limit, and beyond it only when beyond 4 of its own sd too,
    # which adds the tracking's error (module docstring); the drift itself within 0.3 %)
    kft = rep["kf_tracked"]
    summ = kft["summary"]
    print(summ)
    assert summ["limit_pct"] == pytest.approx(max(0.3, 4 * row["sd_pct"]), rel=1e-3)
    for s in kft["samples"]:
        assert s["truth"] == pytest.approx(float(np.interp(s["t"], tr.t, tr.kf)), rel=1e-6)
        assert s["error_over_sd"] == pytest.approx((s["estimate"] - s["truth"]) / s["sd"], rel=1e-3, abs=1e-3)
        if s["compared"]:
            assert abs(s["error_pct"]) < summ["limit_pct"] or abs(s["error_over_sd"]) <= 4.0, s
    assert summ["samples"] > 20 * 90 and summ["beyond_limit"] == 0
    assert abs(summ["drift_tracked_pct"] - summ["drift_truth_pct"]) < 0.3
    # and against its own sd, which is absolute (it carries the identified k_f's)
    assert summ["max_abs_error_over_sd"] < 4.0
    assert abs(summ["drift_truth_pct"]) > 0.6   # the truth moved more than the tolerance
    md = (out / "report.md").read_text()
    assert "k_f tracked against the truth at the same simulated time" in md
