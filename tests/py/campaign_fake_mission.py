"""A stand-in for a campaign's mission command in the campaign tests (given through
OCTO_CAMPAIGN_MISSION).

Reads the mission's options (MissionOptions as JSON) on stdin, writes OUT/report.json with
estimates near the vehicle file's truth (errors and sds from the seed, so they are random but
reproducible) and exits 0. Options of its own: --crash-seed N (exit 3 with a message),
--hang-seed N (sleep for ever), --reject-seed N (k_f rejected, with the firmware's reason in the
report as the mission writes it), --in-process-help (its --help lists --in-process), --die-seed N
(kill the Dask worker process running it).
"""
import argparse
import json
import os
import random
import signal
import sys
import time

p = argparse.ArgumentParser(prog="fake-mission")
p.add_argument("--crash-seed", type=int, action="append", default=[])
p.add_argument("--hang-seed", type=int, action="append", default=[])
p.add_argument("--reject-seed", type=int, action="append", default=[])
p.add_argument("--die-seed", type=int, action="append", default=[])
p.add_argument("--in-process-help", action="store_true")
argv = sys.argv[1:]
if "--help" in argv:
    print("usage: fake-mission < OPTIONS.json" + (" (plant sil: --in-process)" if "--in-process-help" in argv else ""))
    sys.exit(0)
a = p.parse_args(argv)
opts = json.load(sys.stdin)
a.seed, a.vehicle, a.out, a.in_process = opts["seed"], opts["vehicle"], opts["out"], opts["plant"] == "sil"
print(f"fake mission seed {a.seed}", flush=True)
if a.seed in a.crash_seed:
    print("fake: octo-fw exited with status 134 (crash on purpose)", flush=True)
    sys.exit(3)
if a.seed in a.hang_seed:
    print("fake: take-off never ends", flush=True)
    while True:
        time.sleep(1)
if a.seed in a.die_seed:
    os.kill(os.getppid(), signal.SIGKILL)
    time.sleep(5)
veh = json.load(open(a.vehicle))
truth = {"kf": veh.get("kf", 28.0269), "ktau": veh.get("ktau", 0.3869)}
for q, v in zip(("ixx", "iyy", "izz"), veh.get("inertia", [0.0628, 0.0762, 0.1014])):
    truth[q] = v
rng = random.Random(a.seed)
params, checks = {}, []
for q, t in truth.items():
    sd = t * 0.001
    est = t + rng.gauss(0.0, sd)
    acc = not (q == "kf" and a.seed in a.reject_seed)
    params[q] = {"truth": t, "estimate": est, "sd": sd, "error_pct": 100 * (est - t) / t, "accepted": acc,
                 "reason": "ok" if acc else "model", "source": "thrust"}
    checks.append({"check": f"{q} accepted", "ok": acc, "warning_only": False, "detail": ""})
os.makedirs(a.out, exist_ok=True)
rep = {"run": {"seed": a.seed, "in_process": a.in_process, "faults": opts["faults"], "params": opts["params"],
               "plots": opts["plots"]},
       "parameters": params, "checks": checks, "estimator": {"source": "thrust"},
       "pass": all(c["ok"] for c in checks)}
with open(os.path.join(a.out, "report.json"), "w") as f:
    json.dump(rep, f)
sys.exit(0 if rep["pass"] else 1)
