"""Inertia identification with frames lost or reordered on the plant's link (in-process
missions, octo-sil). A frame the firmware never sees, or sees after a newer one, is a gap in
the experiment's samples while the plant held the last command over it. The inertia filters
assume uniform sampling: one update over the gap would take the gyro's change over two frames
for one frame's derivative, an error correlated with the excitation that biases the inertia low
(I_z -2.8 % at 0.95 % reported sd in the campaign's mission 370, the first case below; -2.5 % at
0.79 % on the paper's vehicle, seed 5, reorder 3 %). Each inertia must be within
max(3 sd, 2 %) of the truth when accepted, or be rejected with a reason."""

import json

import pytest

from conftest import read_report, run_gcs

# missions/0370/vehicle.json of the fault campaign (host_tools/campaigns/faults.json)
VEHICLE_370 = {
    "arm_length": 0.3947523420718727, "delay": 0.0,
    "inertia": [0.08467723109997519, 0.06461816473909521, 0.08306636421072906],
    "kf": 36.65700993950314, "kf_drift_per_min": -0.017214197989042678,
    "ktau": 0.2709901155451758, "mass": 2.89540013243964, "motor_tau": 0.0769437806007417,
    "noise": {"attitude_deg": 0.03163461491573848, "gyro": 0.014777654393870174,
              "position": 0.0053031721096442564, "thrust": 0.10946849441304404,
              "torque": 0.0016279950296040223},
    "rotor_scale": [1.0, 1.0, 0.9010647145560062, 1.0, 1.0, 1.0, 1.0, 1.0],
    "thrust_curve": 0.352587732713285,
}

CASES = {
    # name: (vehicle or None for the paper's, seed, faults)
    "m370_burst_reorder": (VEHICLE_370, 31370, ["burst_prob=0.002", "reorder=0.03"]),
    "paper_reorder_s5": (None, 5, ["reorder=0.03"]),
    "paper_drop_s5": (None, 5, ["drop=0.03"]),
    "paper_reorder_s7": (None, 7, ["reorder=0.03"]),
    "paper_drop_s7": (None, 7, ["drop=0.03"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_inertia_right_or_rejected_under_link_faults(tmp_path, case):
    vehicle, seed, faults = CASES[case]
    args = ["mission", "--in-process", "--seed", seed, "--out", tmp_path / "out"]
    if vehicle is not None:
        vfile = tmp_path / "vehicle.json"
        vfile.write_text(json.dumps(vehicle))
        args += ["--vehicle", vfile]
    for f in faults:
        args += ["--fault", f]
    r = run_gcs(*args, timeout=300)
    rep = read_report(tmp_path / "out")
    par = rep["parameters"]
    lines = []
    for k in ("ixx", "iyy", "izz"):
        assert k in par, f"{case}: no {k} in the report (exit {r.returncode}):\n{r.stdout[-2000:]}"
        p = par[k]
        lines.append(f"{k} {p['estimate']} sd {p['sd_pct']} % error {p['error_pct']:+.3f} % "
                     f"accepted {p['accepted']} ({p['reason']})")
    print(f"{case}:\n  " + "\n  ".join(lines))
    for k in ("ixx", "iyy", "izz"):
        p = par[k]
        if p["accepted"]:
            lim = max(3.0 * p["sd_pct"], 2.0)
            assert abs(p["error_pct"]) <= lim, f"{case}: {k} accepted {p['error_pct']:+.3f} % off (limit {lim:.2f} %)"
        else:
            assert p["reason"] and p["reason"] != "ok", f"{case}: {k} rejected without a reason"
