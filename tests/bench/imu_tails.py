#!/usr/bin/env python3
"""The tails of the IMU's k_f and thrust curve over their reported sds, on random vehicles.

    .venv/bin/python tests/bench/imu_tails.py [--runs N] [--seed S] [--sensors imu|imu,rpm]
        [--jobs J] [--no-vibration] [--no-imu-scale] [--seeds S1,S2,...] [--sil PATH] [--rows FILE]

Each run flies the full sequence (experiment 6) in octo-sil on a vehicle of test_ident_imu.py's
draw (imu_vehicle: k_f, k_tau and inertia +/-30 %, motor lag 10-100 ms, delay 0-3 frames,
thrust curve 0-0.5) with the default realistic sensor noise, seed S + i for run i, from a fresh
parameter file. --sensors imu gives ID_SOURCE auto the IMU alone, imu,rpm the IMU with the
ESCs' rotor speeds (imu_rpm). --no-vibration sets the vehicle's `vibration` levels to 0 (what
the rotors' vibration contributes: rerun the outliers with it). --no-imu-scale sets the IMU's
scale errors to 0 (the vehicle's `imu_scale`) and ID_GYR_SCL_SD to 0: the inertias' and the
ratio's sds are then the data's alone, judged without the gyro scale's share. --sil flies another build's
octo-sil (a before / after on the same seeds).

Prints one JSON object: over the accepted k_f, the error's rms and max (%), the error / sd rms,
the counts beyond 3 and 4 sds and beyond max(3 sd, 1 %) (with their seeds, errors and z), the
count within 1 %, k_f's relative sd (median and 95th percentile, %), the first motor lag line's
error rms (%) and count beyond 10 %, the delay found less the true one (counts), the curve's error / sd rms and count beyond 3 sds, k_f's and the curve's var / sd^2 (error / sd's mean
square), for I_x, I_y (accepted) and the ratio k_tau / I_z the error / sd rms, the counts beyond 3 sd
and (seeds) beyond max(3 sd, 2 %), and how many, the quantiles of k_f's degrees of freedom (the
status line "ID sd x F (vibration), NU dof of G clusters"), and the runs not accepted with
their first cause.
"""

import argparse
import concurrent.futures as cf
import json
import math
import os
import random
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "py"))
from test_ident_imu import imu_vehicle  # noqa: E402 (the tests' own draw)

KF = re.compile(r"^ID kf ([-0-9.]+) \+/- ([-0-9.]+) (N accepted|rejected: .*)$")
CURVE = re.compile(r"^ID curve ([-0-9.]+) \+/- ([-0-9.]+)")
DOF = re.compile(r"^ID sd x ([0-9.]+) \(vibration\), ([0-9.]+) dof of (\d+) clusters$")
LAG = re.compile(r"^ID motor lag ([-0-9.]+) \+/- ([-0-9.]+) s delay (-?\d+) fr")
CAUSE = re.compile(r"^ID (rejected|aborted): (.*)$")
INR = re.compile(r"^ID (Ixx|Iyy) ([-0-9.]+) \+/- ([-0-9.]+) (kg m\^2 accepted|rejected: .*)$")
RATIO = re.compile(r"^ID ktau/Izz ([-0-9.]+) \+/- ([-0-9.]+) 1/s\^2 \(gyro")
SCRIPT = "arm; takeoff 5; wait hold; experiment 6; wait experiment"


def fly(sil, seed, sensors, no_vib, no_scale=False):
    veh = imu_vehicle(random.Random(seed))
    if no_vib:
        veh["vibration"] = {"accel": 0.0, "gyro": 0.0}
    pre = ""
    if no_scale:
        veh["imu_scale"] = 0.0
        pre = "param ID_GYR_SCL_SD 0; "
    with tempfile.TemporaryDirectory() as d:
        vf, pf = Path(d) / "v.json", Path(d) / "p.parm"
        vf.write_text(json.dumps(veh))
        r = subprocess.run([str(sil), "--seed", str(seed), "--vehicle", str(vf), "--sensors", sensors, "--params",
                            str(pf), "--duration", "900", "--script", f"{pre}param ID_SEED {seed}; {SCRIPT}"],
                           capture_output=True, text=True, timeout=600)
    row = {"seed": seed, "kf_true": veh["kf"], "c_true": veh["thrust_curve"], "lag_true": veh["motor_tau"],
           "delay_true": round(veh["delay"] * 90.0),
           "ix_true": veh["inertia"][0], "iy_true": veh["inertia"][1], "kz_true": veh["ktau"] / veh["inertia"][2]}
    for ln in (x.split("octo-fw: ", 1)[1] for x in r.stderr.splitlines() if "octo-fw: " in x):
        if (m := KF.match(ln)):
            row.update(kf=float(m[1]), kf_sd=float(m[2]), ok="accepted" in m[3], why=m[3])
        elif (m := CURVE.match(ln)) and "c" not in row:
            row.update(c=float(m[1]), c_sd=float(m[2]))
        elif (m := LAG.match(ln)) and "lag" not in row:
            row.update(lag=float(m[1]), lag_sd=float(m[2]), delay=int(m[3]))
        elif (m := DOF.match(ln)):
            row.update(dof=float(m[2]), vib=float(m[1]))
        elif (m := INR.match(ln)) and "accepted" in m[4]:
            ax = "ix" if m[1] == "Ixx" else "iy"
            row.update({ax: float(m[2]), ax + "_sd": float(m[3])})
        elif (m := RATIO.match(ln)):
            row.update(kz=float(m[1]), kz_sd=float(m[2]))
        elif (m := CAUSE.match(ln)) and "cause" not in row:
            row["cause"] = m[2]
    return row


def tail(rows, k):
    """a published quantity's error / sd rms, count beyond 3 sd, beyond max(3 sd, 2 %) (seeds) and count"""
    v = [(r["seed"], r[k] - r[k + "_true"], r[k + "_sd"], r[k + "_true"]) for r in rows if r.get(k + "_sd")]
    if not v:
        return None
    z = [e / s for _, e, s, _ in v]
    return [round(math.sqrt(sum(q * q for q in z) / len(z)), 3), sum(abs(q) > 3.0 for q in z),
            [s for s, e, sd, t in v if abs(e) > max(3.0 * sd, 0.02 * t)], len(v)]


def summary(rows):
    acc = [r for r in rows if r.get("ok")]
    rms = lambda v: math.sqrt(sum(x * x for x in v) / len(v)) if v else None  # noqa: E731
    z = [(r["kf"] - r["kf_true"]) / r["kf_sd"] for r in acc]
    err = [100.0 * (r["kf"] / r["kf_true"] - 1.0) for r in acc]
    zc = [(r["c"] - r["c_true"]) / r["c_sd"] for r in acc if r.get("c_sd")]
    out = lambda k: [(r["seed"], round(e, 2), round(q, 2)) for r, e, q in zip(acc, err, z) if k(r, e, q)]  # noqa: E731
    dof = sorted(r["dof"] for r in acc if "dof" in r)
    lag = [100.0 * (r["lag"] / r["lag_true"] - 1.0) for r in acc if "lag" in r]
    dly = {}
    for r in acc:
        if "delay" in r:
            k = str(r["delay"] - r["delay_true"])
            dly[k] = dly.get(k, 0) + 1
    sdp = sorted(100.0 * r["kf_sd"] / r["kf"] for r in acc)
    causes = {}
    for r in rows:
        if not r.get("ok"):
            k = r.get("cause") or r.get("why") or "no k_f line"
            causes[k] = causes.get(k, 0) + 1
    return {
        "runs": len(rows), "accepted": len(acc),
        "kf_err_rms_pct": rms(err), "kf_err_max_pct": max(map(abs, err)) if err else None, "kf_z_rms": rms(z),
        "kf_beyond_3sd": out(lambda r, e, q: abs(q) > 3.0), "kf_beyond_4sd": out(lambda r, e, q: abs(q) > 4.0),
        "kf_beyond_max_3sd_1pct": out(lambda r, e, q: abs(e) > max(3.0 * abs(e / q) if q else 0.0, 1.0)),
        "kf_within_1pct": sum(abs(e) <= 1.0 for e in err),
        "kf_sd_pct_median_p95": [sdp[len(sdp) // 2], sdp[int(0.95 * (len(sdp) - 1))]] if sdp else None,
        "lag_err_rms_pct": rms(lag), "lag_beyond_10pct": sum(abs(e) > 10.0 for e in lag),
        "delay_found_less_true": dly,
        "curve_z_rms": rms(zc), "curve_beyond_3sd": sum(abs(q) > 3.0 for q in zc),
        "kf_var_over_sd2": rms(z) ** 2 if z else None,
        "curve_var_over_sd2": rms(zc) ** 2 if zc else None,
        **{f"{k}_z_rms_beyond_3sd_beyond_max_3sd_2pct": tail(rows, k) for k in ("ix", "iy", "kz")},
        "kf_dof_quantiles_0_5_50_95_100": [dof[int(p * (len(dof) - 1))] for p in (0, 0.05, 0.5, 0.95, 1)] if dof else None,
        "not_accepted": causes,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=300)
    ap.add_argument("--seed", type=int, default=600000)
    ap.add_argument("--seeds", help="comma-separated seeds (instead of --runs / --seed)")
    ap.add_argument("--sensors", default="imu,rpm")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--no-vibration", action="store_true")
    ap.add_argument("--no-imu-scale", action="store_true")
    ap.add_argument("--sil", default=str(ROOT / "build" / "octo-sil"))
    ap.add_argument("--rows", help="write every run's row (JSON) to this file, for a paired before / after")
    a = ap.parse_args()
    seeds = [int(s) for s in a.seeds.split(",")] if a.seeds else list(range(a.seed, a.seed + a.runs))
    with cf.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
        rows = list(ex.map(lambda s: fly(a.sil, s, a.sensors, a.no_vibration, a.no_imu_scale), seeds))
    res = summary(rows)
    res.update(sensors=a.sensors, seeds=[seeds[0], seeds[-1]], vibration=not a.no_vibration,
               imu_scale=not a.no_imu_scale)
    if a.seeds:
        res["rows"] = [{k: r.get(k) for k in ("seed", "kf", "kf_sd", "kf_true", "c", "c_sd", "c_true", "dof", "vib",
                                                   "ix", "ix_sd", "ix_true", "iy", "iy_sd", "iy_true", "kz", "kz_sd", "kz_true")}
                       for r in rows]
    if a.rows:
        Path(a.rows).write_text(json.dumps(rows))
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    os.chdir(ROOT)
    main()
