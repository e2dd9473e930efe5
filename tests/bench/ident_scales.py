#!/usr/bin/env python3
"""Each rotor's effectiveness from the IMU and the rotor speeds on random vehicles.

    .venv/bin/python tests/bench/ident_scales.py [--runs N] [--seed S] [--jobs J] [--weak 1|2]

Each run flies the full sequence (experiment 6) in octo-sil on a vehicle of ident_sources.py's
draw (motor lag 10-100 ms, delay 0-3 frames, thrust curve 0-0.5, k_f, k_tau and inertia +/-30 %,
one rotor at 0.8-1.0; with --weak 2 a second one), the rotors' scales unknown to the firmware
(MOT_SCALEj left at 1), with the default realistic sensor noise, --sensors imu,rpm (ID_SOURCE
auto takes imu_rpm).

Prints one JSON object: the runs not identified (k_f not accepted) with their first cause; over
the accepted runs' scales (against the truth over its median, as the firmware normalises them)
the error rms (%), the error / sd rms, the count beyond max(3 sd, 1 %) and beyond 3 sd, the
largest error, the runs whose every scale is within 1 %, the runs whose scales were not said
(not separated); and k_f, I_x, I_y and k_tau / I_z as ident_sources.py judges them.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ident_sources as src

NUM = r"([-0-9.]+)"
SCALE = re.compile(r"^ID scale (1-4|5-8) " + " ".join([NUM] * 4) + "$")
SCALE_SD = re.compile(r"^ID scale sd (1-4|5-8) " + " ".join([NUM] * 4) + "$")


def vehicle(seed, weak):
    veh = src.vehicle(random.Random(seed))
    if weak > 1:
        r = random.Random(seed * 3 + 7)
        j = r.choice([k for k in range(8) if veh["rotor_scale"][k] == 1.0])
        veh["rotor_scale"][j] = r.uniform(0.8, 1.0)
    return veh


def fly(args):
    seed, weak, tmp = args
    veh = vehicle(seed, weak)
    d = Path(tmp)
    vf, prm = d / f"v{seed}.json", d / f"p{seed}.parm"
    vf.write_text(json.dumps(veh))
    steps = [f"param ID_SEED {seed}", "arm", "takeoff 5", "wait hold", "experiment 6", "wait experiment"]
    r = subprocess.run([str(src.SIL), "--seed", str(seed), "--vehicle", str(vf), "--sensors", "imu,rpm",
                        "--params", str(prm), "--duration", "900", "--script", "; ".join(steps)],
                       capture_output=True, text=True, timeout=300, check=False)
    prm.unlink(missing_ok=True)
    out = {"causes": [], "sc": {}, "sd": {}}
    for ln in r.stderr.splitlines():
        ln = ln.removeprefix("octo-fw: ")
        for k, rx in src.RX.items():
            m = re.match(rx, ln)
            if m:
                out[k] = (float(m.group(1)), float(m.group(2)), "accepted" in m.group(3) or "ratio" in m.group(3))
        for rx, key in ((SCALE, "sc"), (SCALE_SD, "sd")):
            m = rx.match(ln)
            if m:
                out[key][m.group(1)] = [float(m.group(i)) for i in range(2, 6)]
        m = src.CAUSE.match(ln)
        if m:
            out["causes"].append(m.group(2))
        if ln.startswith("ID scales"):
            out["causes"].append(ln)
    return seed, veh, out


def rms(v):
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else None


def summarise(runs):
    res = {"runs": len(runs), "not_identified": 0, "causes": {}, "scales_not_said": 0}
    err, zs, beyond, beyond3, worst = [], [], 0, 0, []
    q = {k: ([], [], 0) for k in ("kf", "ixx", "iyy", "ratio")}
    for _, veh, o in runs:
        if not o.get("kf", (0, 0, False))[2]:
            res["not_identified"] += 1
            for c in o["causes"][:1] or ["no result"]:
                res["causes"][c] = res["causes"].get(c, 0) + 1
            continue
        t = src.truth(veh)
        for k, (e, z, b) in q.items():
            v = o.get(k)
            if v and v[2]:
                e.append(100.0 * (v[0] / t[k] - 1.0))
                z.append((v[0] - t[k]) / v[1] if v[1] > 0 else math.inf)
                q[k] = (e, z, b + (abs(v[0] - t[k]) > max(3.0 * v[1], 0.01 * t[k])))
        if len(o["sc"]) < 2 or len(o["sd"]) < 2:
            res["scales_not_said"] += 1
            continue
        sc, sd = o["sc"]["1-4"] + o["sc"]["5-8"], o["sd"]["1-4"] + o["sd"]["5-8"]
        s = sorted(veh["rotor_scale"])
        med = 0.5 * (s[3] + s[4])
        tr = [x / med for x in veh["rotor_scale"]]
        for j in range(8):
            e = sc[j] - tr[j]
            err.append(e)
            zs.append(e / sd[j] if sd[j] > 0 else math.inf)
            beyond += abs(e) > max(3.0 * sd[j], 0.01)
            beyond3 += abs(e) > 3.0 * sd[j]
        worst.append(max(abs(sc[j] - tr[j]) for j in range(8)))
    res["scale"] = {"n": len(err), "err_rms_pct": 100.0 * rms(err) if err else None,
                    "z_rms": rms(zs), "beyond_max_3sd_1pct": beyond, "beyond_3sd": beyond3,
                    "err_max_pct": 100.0 * max(map(abs, err)) if err else None,
                    "runs_every_rotor_within_1pct": sum(w <= 0.01 for w in worst), "runs_with_scales": len(worst)}
    for k, (e, z, b) in q.items():
        if e:
            res[k] = {"accepted": len(e), "err_rms_pct": rms(e), "z_rms": rms(z), "beyond_max_3sd_1pct": b}
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=30000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--weak", type=int, choices=(1, 2), default=1)
    a = ap.parse_args(argv)
    if not src.SIL.exists():
        sys.exit(f"ident_scales: {src.SIL} missing (make first)")
    with tempfile.TemporaryDirectory(prefix="bench-scales-") as tmp, cf.ProcessPoolExecutor(a.jobs) as ex:
        runs = list(ex.map(fly, [(a.seed + i, a.weak, tmp) for i in range(a.runs)]))
    print(json.dumps({"seed": a.seed, "weak": a.weak, **summarise(runs)}))


if __name__ == "__main__":
    main()
