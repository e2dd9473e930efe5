#!/usr/bin/env python3
"""Identification per source on random vehicles (bench item 9; also runs alone).

    .venv/bin/python tests/bench/ident_sources.py [--runs N] [--seed S] [--jobs J]

Each run flies the full sequence (experiment 6) in octo-sil on a vehicle of the tests' ranges
(motor lag 10-100 ms, delay 0-3 frames, thrust curve 0-0.5, k_f, k_tau and inertia +/-30 %)
with the default realistic sensor noise, three ways on the same vehicle and seed:

- thrust: the thrust and torque rows (ID_SOURCE 1), one rotor at 0.8-1.0 unknown to the firmware;
- imu_only: the IMU alone (--sensors imu: ID_SOURCE auto takes imu, the motor's lag, delay and
  curve from the accelerometer's response to the throttles, k_f from it with the mass known),
  the rotors' scales given (MOT_SCALEj set to the truth, as from a bench);
- imu: no thrust or torque rows (--sensors imu,rpm: ID_SOURCE auto takes imu_rpm, the motor's
  lag and delay from the ESC speeds, k_f from the accelerometer), the rotors' scales given
  (MOT_SCALEj set to the truth, as from a bench);
- imu, a weak rotor: as imu, with the 0.8-1.0 rotor unknown to the firmware (the rotor speeds
  and the gyro separate the rotors: each rotor's effectiveness is identified, and the run's
  values must be right; a run the estimate cannot separate is rejected naming the cause);
- imu_tq: as imu, with the ESCs' shaft torques served too (--sensors imu,rpm,torque: auto takes
  imu_rpm_torque, k_tau from the torques), as an ESC's current gives them: an offset of
  0.1-0.5 A, current noise 0.02-0.1 A, KV 500-1000.

--no-imu-scale sets the IMU's scale errors (the vehicle's `imu_scale`) and ID_GYR_SCL_SD to 0:
the inertias' and the ratio's sds are then the data's alone. --no-vibration sets the vehicle's
`vibration` levels to 0 (what the rotors' vibration contributes).

Prints one JSON object: per source and quantity the accepted count, the error's rms and max (%),
the shares within 1 % and 2 %, the error / sd rms and its square's mean (var_over_sd2), and
the runs beyond max(3 sd, tolerance) (beyond_3sd_and_tol:
seed, error %, z; the tolerance 1 % for k_f and k_tau, 2 % for the inertias and the ratio); the
rejections with their causes, the delay right and the lag within 10 %; and per IMU source
(imu_only, imu) and quantity its agreement with the thrust rows' estimate of the same vehicle
(difference over the combined sd). --sources flies only the listed ones (the agreement needs
thrust among them).
"""

import argparse
import concurrent.futures as cf
import json
import math
import random
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SIL = ROOT / "build" / "octo-sil"
PAPER_I = [0.0628, 0.0762, 0.1014]
PAPER = {"kf": 28.0269, "ktau": 0.3869}
RX = {
    "kf": r"^ID kf ([-0-9.]+) \+/- ([-0-9.]+) (N accepted|rejected: .*)$",
    "ktau": r"^ID ktau ([-0-9.]+) \+/- ([-0-9.]+) (N m accepted|N m \((VEH_IZZ prior|ESC torque)\) accepted|rejected: .*)$",
    "ixx": r"^ID Ixx ([-0-9.]+) \+/- ([-0-9.]+) (kg m\^2 accepted|rejected: .*)$",
    "iyy": r"^ID Iyy ([-0-9.]+) \+/- ([-0-9.]+) (kg m\^2 accepted|rejected: .*)$",
    "izz": r"^ID Izz ([-0-9.]+) \+/- ([-0-9.]+) (kg m\^2 accepted|rejected: .*)$",
    "ratio": r"^ID ktau/Izz ([-0-9.]+) \+/- ([-0-9.]+) 1/s\^2 (\(gyro: the ratio\)|rejected: .*)$",
}
LAG = re.compile(r"^ID motor lag ([-0-9.]+) \+/- ([-0-9.]+) s delay (\d+) fr$")
CAUSE = re.compile(r"^ID (rejected|aborted): (.*)$")
HOWS = ("thrust", "imu_only", "imu", "imu_weak", "imu_tq")
# the tolerance of "beyond max(3 sd, tolerance)": 1 % for k_f and k_tau, 2 % for the inertias and the ratio
TOL = {"kf": 0.01, "ktau": 0.01, "ixx": 0.02, "iyy": 0.02, "izz": 0.02, "ratio": 0.02}


def vehicle(rng):
    inertia = [i * rng.uniform(0.7, 1.3) for i in PAPER_I]
    inertia[2] = min(inertia[2], inertia[0] + inertia[1] - 1e-4)  # a rigid body's inertia
    scale = [1.0] * 8
    scale[rng.randrange(8)] = rng.uniform(0.8, 1.0)
    return {"kf": PAPER["kf"] * rng.uniform(0.7, 1.3), "ktau": PAPER["ktau"] * rng.uniform(0.7, 1.3),
            "inertia": inertia, "motor_tau": rng.uniform(0.010, 0.100), "delay": rng.randint(0, 3) / 90.0,
            "thrust_curve": rng.uniform(0.0, 0.5), "rotor_scale": scale}


def fly(veh, seed, how, tmp, no_scale=False, no_vib=False):
    d = Path(tmp)
    prm = d / f"p{seed}{how}.parm"
    steps = [f"param ID_SEED {seed}"]
    if no_scale:
        veh = dict(veh, imu_scale=0.0)
        steps.append("param ID_GYR_SCL_SD 0")
    if no_vib:
        veh = dict(veh, vibration={"accel": 0.0, "gyro": 0.0})
    sensors = "imu,rpm,thrust,torque"
    if how == "thrust":
        steps.append("param ID_SOURCE 1")
    else:
        sensors = {"imu_tq": "imu,rpm,torque", "imu_only": "imu"}.get(how, "imu,rpm")
        if how == "imu_tq":
            esc = random.Random(seed * 7 + 1)
            veh = dict(veh, esc_current_offset=esc.uniform(0.1, 0.5), noise={"current": esc.uniform(0.02, 0.1)},
                       esc_kt=60.0 / (2.0 * math.pi * esc.uniform(500.0, 1000.0)))
        if how in ("imu_only", "imu", "imu_tq"):
            steps += [f"param MOT_SCALE{j + 1} {s!r}" for j, s in enumerate(veh["rotor_scale"])]
    steps += ["arm", "takeoff 5", "wait hold", "experiment 6", "wait experiment"]
    (d / f"v{seed}{how}.json").write_text(json.dumps(veh))  # with the ESCs' offset, noise and KV
    r = subprocess.run([str(SIL), "--seed", str(seed), "--vehicle", str(d / f"v{seed}{how}.json"), "--sensors", sensors,
                        "--params", str(prm), "--duration", "900", "--script", "; ".join(steps)],
                       capture_output=True, text=True, timeout=300, check=False)
    prm.unlink(missing_ok=True)
    out = {"causes": []}
    for ln in r.stderr.splitlines():
        ln = ln.removeprefix("octo-fw: ")
        for k, rx in RX.items():
            m = re.match(rx, ln)
            if m:
                out[k] = (float(m.group(1)), float(m.group(2)), "accepted" in m.group(3) or "ratio" in m.group(3))
        m = LAG.match(ln)
        if m:
            out["lag"] = (float(m.group(1)), float(m.group(2)), int(m.group(3)))
        m = CAUSE.match(ln)
        if m:
            out["causes"].append(m.group(2))
    return out


def truth(veh):
    i = veh["inertia"]
    return {"kf": veh["kf"], "ktau": veh["ktau"], "ixx": i[0], "iyy": i[1], "izz": i[2], "ratio": veh["ktau"] / i[2]}


def one(args):
    seed, tmp, hows, no_scale, no_vib = args
    veh = vehicle(random.Random(seed))
    return seed, veh, {h: fly(veh, seed, h, tmp, no_scale, no_vib) for h in hows}


def summarise(runs, hows=HOWS):
    res = {}
    for how in hows:
        s = {"runs": len(runs), "rejected": 0, "causes": {}}
        for k in RX:
            zs, errs, tails = [], [], []
            for seed, veh, r in runs:
                v = r[how].get(k)
                if not v or not v[2]:
                    continue
                t = truth(veh)[k]
                errs.append(100.0 * (v[0] / t - 1.0))
                z = (v[0] - t) / v[1] if v[1] > 0 else math.inf
                zs.append(z)
                if abs(z) > 3.0 and abs(v[0] / t - 1.0) > TOL[k]:
                    tails.append([seed, round(errs[-1], 2), round(z, 2)])
            if zs:
                s[k] = {"accepted": len(zs), "err_rms_pct": math.sqrt(sum(e * e for e in errs) / len(errs)),
                        "z_rms": math.sqrt(sum(z * z for z in zs) / len(zs)),
                        "var_over_sd2": sum(z * z for z in zs) / len(zs),
                        "beyond_3sd_and_tol": tails, "err_max_pct": max(abs(e) for e in errs),
                        "within_1pct": sum(abs(e) <= 1.0 for e in errs) / len(errs),
                        "within_2pct": sum(abs(e) <= 2.0 for e in errs) / len(errs)}
        lag_ok = delay_ok = n_lag = 0
        for seed, veh, r in runs:
            x = r[how]
            if not x.get("kf", (0, 0, False))[2]:
                s["rejected"] += 1
                for c in x["causes"][:1] or ["no result"]:
                    s["causes"][c] = s["causes"].get(c, 0) + 1
            if "lag" in x and x.get("kf", (0, 0, False))[2]:
                n_lag += 1
                lag_ok += abs(x["lag"][0] / veh["motor_tau"] - 1.0) <= 0.10
                delay_ok += x["lag"][2] == round(veh["delay"] * 90.0)
        s["lag_within_10pct"] = lag_ok / n_lag if n_lag else None
        s["delay_right"] = delay_ok / n_lag if n_lag else None
        res[how] = s
    # each IMU source's agreement with the thrust rows' estimate of the same vehicle
    for how in ("imu", "imu_only"):
        if how not in hows or "thrust" not in hows:
            continue
        agree = {}
        for k in ("kf", "ixx", "iyy"):
            d = []
            for seed, veh, r in runs:
                a, b = r[how].get(k), r["thrust"].get(k)
                if a and b and a[2] and b[2]:
                    d.append((a[0] - b[0]) / math.hypot(a[1], b[1]))
            if d:
                agree[k] = {"n": len(d), "rms": math.sqrt(sum(x * x for x in d) / len(d)),
                            "beyond_3": sum(abs(x) > 3 for x in d)}
        res[f"{how}_vs_thrust"] = agree
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=30000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--sources", default=",".join(HOWS), help="comma-separated, of " + ",".join(HOWS))
    ap.add_argument("--no-imu-scale", action="store_true",
                    help="the IMU's scale errors 0 and ID_GYR_SCL_SD 0 (the sds the data's alone)")
    ap.add_argument("--no-vibration", action="store_true", help="the rotors' vibration levels 0")
    a = ap.parse_args(argv)
    hows = tuple(h for h in HOWS if h in a.sources.split(","))
    bad = set(a.sources.split(",")) - set(HOWS)
    if bad or not hows:
        ap.error(f"--sources: unknown {sorted(bad)}" if bad else "--sources: none given")
    if not SIL.exists():
        sys.exit(f"ident_sources: {SIL} missing (make first)")
    with tempfile.TemporaryDirectory(prefix="bench-sources-") as tmp, cf.ProcessPoolExecutor(a.jobs) as ex:
        runs = list(ex.map(one, [(a.seed + i, tmp, hows, a.no_imu_scale, a.no_vibration) for i in range(a.runs)]))
    print(json.dumps({"runs": a.runs, "seed": a.seed, **summarise(runs, hows)}))


if __name__ == "__main__":
    main()
