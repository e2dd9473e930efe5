#!/usr/bin/env python3
"""make bench: Octo-SIL's performance figures, measured side by side.

Run by `make bench` (which builds the harnesses first) as
    .venv/bin/python tests/bench/bench.py [--repeats N] [--only ITEMS] [--quick] [--no-arm] [--readme]
Prints one table (each timed figure: median of N runs with [min, max]; each count: exact,
deterministic) beside its reference measured in the same run and its target, then the
machine and the exact command behind each figure, and writes build/bench.json and the table
as markdown (build/bench.md); --readme also puts that table into docs/performance.md.

Items:
  speed   1. closed loop: octo-sim --lockstep + octo-fw (--actuation dref and data25) + a
             pymavlink ground station, 120 s simulated: arm, take-off to 10 m, hold,
             MAV_CMD_USER_1 param1=1 (rotor-coefficient experiment) once hovering if the
             firmware has it; simulated s per wall s, beside a bare UDP ping-pong between two
             processes with the same datagrams per frame (build/bench/pingpong pp)
  step    2. octo-fw's 90 Hz step without I/O (build/bench/bench-step: firmware/app + core,
             stub HAL): instructions per step on the host (valgrind --tool=callgrind) and on
             Cortex-M4F (QEMU mps2-an386 + tests/arm's counting plugin); per build (float,
             fixed) on M4F and M0 (ARMv6-M code counted on mps2-an386) in HOLD, experiments
             1 (rotor), 2 (validation), 3 (inertia Ixx), the steps that say something (a
             parameter change, origin shift, frames missing, experiment aborts, link back,
             take-off, landing, mode changes, time limits) and between frames, median and max,
             the float/fixed ratio per phase, and where the m0-fixed step's instructions go
             (tests/arm/insn-profile.sh: top routines); the allocator alone
  memory  3. the core's .text/.data/.bss on Cortex-M4F, M0 and M0 fixed (tests/arm's images), the core
             state the app owns (sizeof), peak RSS of octo-fw and octo-sim (wait4 of the
             flights of item 1)
  alloc   4. build/bench/bench-alloc: priority allocator vs pseudo-inverse + clipping
  estim   5. build/bench/bench-estim: Monte Carlo of k_f, lag-aware vs CRLB, paper's plain;
             build/bench/bench-motor: the joint rotor-model estimator on random vehicles
  sim     6. physics alone (build/bench/bench-physics) and octo-sim --lockstep driven by the
             tightest client (build/bench/pingpong client)
  sil     7. octo-sil (app + plant in one process): simulated s per wall s of a hovering
             flight beside the physics alone in the same run (target >= 2,000x and >= 50 %
             of it); its peak memory; whole missions: octo-gcs mission --in-process with and
             without plots against the UDP mission (octo-sim + octo-fw)
  campaign 8. octo-gcs campaign throughput on a local Dask cluster of 1 and of 2 workers (the
             same 60 missions: the paper's vehicle, random seeds, experiment 6, in-process plant
             when octo-gcs mission has it): missions per minute, the scaling efficiency
             rate(2) / (2 rate(1)), the CPU seconds of a mission on its worker and the rate
             they allow on idle cores (the machine's load is printed beside the rates)
  sources 9. identification per source (tests/bench/ident_sources.py): the full sequence on
             random vehicles from the thrust rows, from the IMU alone and from the IMU with the
             ESC speeds (the rotors' scales given), from the IMU and speeds with a weak rotor
             unknown, and with the ESC torques too; accuracy, error / sd, rejections and their
             causes, and the IMU's agreement with the thrust rows on the same vehicle
"""

import argparse
import json
import math
import os
import platform
import re
import shlex
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
B = REPO / "build"
BB = B / "bench"
ARM = B / "arm"
HZ = 90.0
FLIGHT_S = 120.0
ROWS_OUT = 5 + 6 * 36     # DATA of rows 1 16 17 21 35 36, as octo-fw selects them
PATTERNS = {"dref": (8, 509), "data25": (1, 41)}   # datagrams back per frame, bytes each


def rel(p):
    try:
        return str(Path(os.path.abspath(p)).relative_to(REPO))
    except ValueError:
        return str(p)


def cmdline(argv):
    return " ".join(shlex.quote(rel(a) if str(a).startswith(str(REPO)) else str(a)) for a in argv)


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def mmm(xs):
    xs = [x for x in xs if x is not None]
    if not xs:
        return None
    return {"median": statistics.median(xs), "min": min(xs), "max": max(xs), "n": len(xs)}


def machine():
    model = platform.processor() or "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": model, "cores": os.cpu_count(), "kernel": platform.release(),
            "python": platform.python_version(), "load_avg_1m": round(os.getloadavg()[0], 2),
            "date_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())}


# ====================================================================== table
class Report:
    def __init__(self):
        self.rows = []
        self.data = {}
        self.commands = {}

    def row(self, item, figure, value, spread="", ref="", target="", ok=None, cmd=None):
        self.rows.append({"item": item, "figure": figure, "value": value, "spread": spread,
                          "reference": ref, "target": target, "ok": ok, "command": cmd})

    def markdown(self):
        esc = lambda x: str(x).replace("|", "\\|")
        out = ["| # | figure | value | [min .. max] | reference (same run) | target | |",
               "|---|---|--:|---|---|---|---|"]
        for r in self.rows:
            out.append("| " + " | ".join(esc(x) for x in (
                r["item"], r["figure"].strip(), r["value"], r["spread"], r["reference"], r["target"],
                {True: "ok", False: "**miss**", None: ""}[r["ok"]])) + " |")
        return "\n".join(out) + "\n"

    def print(self, out=sys.stdout):
        head = ("#", "figure", "value", "[min, max]", "reference (same run)", "target", "")
        cols = [[str(r["item"]), r["figure"], r["value"], r["spread"], r["reference"], r["target"],
                 {True: "ok", False: "MISS", None: ""}[r["ok"]]] for r in self.rows]
        w = [max(len(head[i]), *(len(c[i]) for c in cols)) if cols else len(head[i]) for i in range(7)]
        w[4] = min(w[4], 48)
        line = lambda c: "  ".join(x.ljust(w[i]) if i != 2 else x.rjust(w[i]) for i, x in enumerate(c)).rstrip()
        print(line(head), file=out)
        print("  ".join("-" * x for x in w), file=out)
        last = None
        for r, c in zip(self.rows, cols):
            if last is not None and r["item"] != last:
                print("", file=out)
            last = r["item"]
            print(line(c), file=out)


def fmt(x, nd=0, unit=""):
    if x is None:
        return "n/a"
    if isinstance(x, float) and nd == 0:
        return f"{x:,.0f}{unit}"
    return f"{x:,.{nd}f}{unit}"


def spread(s, nd=0, unit=""):
    return f"[{fmt(s['min'], nd)} .. {fmt(s['max'], nd)}]{unit}" if s else ""


# ====================================================================== item 1: closed loop
class Flight:
    """octo-sim --lockstep + octo-fw + a pymavlink ground station, one flight."""

    def __init__(self, actuation, duration, workdir):
        self.act, self.duration, self.dir = actuation, duration, Path(workdir)

    def run(self):
        os.environ.setdefault("MAVLINK20", "1")
        from pymavlink import mavutil
        mav = mavutil.mavlink
        xp, xl, mp, gp = free_port(), free_port(), free_port(), free_port()
        self.sim_argv = [B / "octo-sim", "--xp-port", xp, "--data-out", f"127.0.0.1:{xl}", "--lockstep",
                         "--duration", f"{self.duration:g}", "--lcm", f"file://{self.dir}/truth.lcm"]
        self.fw_argv = [B / "octo-fw", "--xplane", f"127.0.0.1:{xp}", "--xp-listen", xl,
                        "--mavlink-listen", mp, "--gcs", f"127.0.0.1:{gp}", "--actuation", self.act,
                        "--params", self.dir / "params.parm", "--lcm", f"file://{self.dir}/fw.lcm"]
        gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{gp}", source_system=255, source_component=190)
        sim = subprocess.Popen([str(a) for a in self.sim_argv], stdin=subprocess.DEVNULL,
                               stdout=subprocess.DEVNULL, stderr=open(self.dir / "sim.stderr", "wb"))
        fw = subprocess.Popen([str(a) for a in self.fw_argv], stdin=subprocess.DEVNULL,
                              stdout=subprocess.DEVNULL, stderr=open(self.dir / "fw.stderr", "wb"))
        done = {}
        hwm = {"sim": None, "fw": None}

        def reap():
            _, status, _ = os.wait4(sim.pid, 0)
            done["t"] = time.monotonic()
            done["status"] = status
            sim.returncode = os.waitstatus_to_exitcode(status)

        def watch():
            # VmHWM of each process (its own peak RSS; wait4's ru_maxrss would include the
            # size of this Python process, which the child inherits across fork + exec)
            while "t" not in done:
                for k, p in (("sim", sim), ("fw", fw)):
                    v = vm_hwm_kb(p.pid)
                    if v is not None:
                        hwm[k] = max(hwm[k] or 0, v)
                time.sleep(0.01)

        threading.Thread(target=watch, daemon=True).start()

        waiter = threading.Thread(target=reap, daemon=True)
        waiter.start()
        texts, res = [], {"actuation": self.act, "experiment": None}
        try:
            if gcs.wait_heartbeat(timeout=10) is None:
                raise RuntimeError("no HEARTBEAT from octo-fw")

            def command(cmd, *p, timeout=2.0):
                p = list(p) + [0.0] * (7 - len(p))
                gcs.mav.command_long_send(1, 1, cmd, 0, *p)
                end = time.monotonic() + timeout
                while time.monotonic() < end:
                    m = gcs.recv_match(blocking=True, timeout=0.05)
                    if m is None:
                        continue
                    if m.get_type() == "STATUSTEXT":
                        texts.append(m.text)
                    if m.get_type() == "COMMAND_ACK" and m.command == cmd:
                        return m.result
                return None

            t_arm = None
            end = time.monotonic() + 10
            while time.monotonic() < end:
                if command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout=0.5) == mav.MAV_RESULT_ACCEPTED:
                    t_arm = time.monotonic()
                    break
                time.sleep(0.05)
            if t_arm is None:
                raise RuntimeError("could not arm")
            if command(mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10.0) != mav.MAV_RESULT_ACCEPTED:
                raise RuntimeError("take-off refused")
            asked = False
            while "t" not in done:
                m = gcs.recv_match(blocking=True, timeout=0.02)
                if m is not None and m.get_type() == "STATUSTEXT":
                    texts.append(m.text)
                if not asked and "Mode HOLD" in texts:
                    asked = True
                    r = command(mav.MAV_CMD_USER_1, 1.0, timeout=1.0)
                    # octo-fw answers IN_PROGRESS when the experiment starts (ACCEPTED when it ends)
                    res["experiment"] = {mav.MAV_RESULT_ACCEPTED: "accepted",
                                         mav.MAV_RESULT_IN_PROGRESS: "accepted",
                                         mav.MAV_RESULT_UNSUPPORTED: "not in this build"}.get(r, f"result {r}")
            waiter.join(timeout=FLIGHT_S * 2)
            wall = done["t"] - t_arm
            res.update(wall_s=wall, sim_s=self.duration, x_realtime=self.duration / wall,
                       sim_rss_kb=hwm["sim"], sim_exit=sim.returncode,
                       reached_hold="Mode HOLD" in texts,
                       experiment_done="ID done" in texts,
                       experiment_texts=[t for t in texts if "xperiment" in t or t.startswith("ID ")])
        finally:
            if sim.returncode is None and "t" not in done:
                sim.kill()
            waiter.join(timeout=5)
            if fw.poll() is None:
                v = vm_hwm_kb(fw.pid)
                res["fw_rss_kb"] = max(hwm["fw"] or 0, v or 0) or None
                fw.send_signal(signal.SIGTERM)
                fw.wait(timeout=10)
            gcs.close()
        res["texts"] = texts[:20]
        return res


def vm_hwm_kb(pid):
    """Peak resident set of a live process (VmHWM, kB), None if gone."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def pingpong(frames, back_n, back_b):
    argv = [BB / "pingpong", "pp", frames, ROWS_OUT, back_n, back_b]
    out = subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=120, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1]), cmdline(argv)


def sim_alone(act, duration):
    xp, xl = free_port(), free_port()
    sim_argv = [B / "octo-sim", "--xp-port", xp, "--data-out", f"127.0.0.1:{xl}", "--lockstep",
                "--duration", f"{duration:g}"]
    cl_argv = [BB / "pingpong", "client", xp, xl, act]
    sim = subprocess.Popen([str(a) for a in sim_argv], stdin=subprocess.DEVNULL,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        out = subprocess.run([str(a) for a in cl_argv], capture_output=True, text=True, timeout=120)
    finally:
        try:
            sim.wait(timeout=10)
        except subprocess.TimeoutExpired:
            sim.kill()
            sim.wait()
    r = json.loads(out.stdout.strip().splitlines()[-1])
    return r, f"{cmdline(sim_argv)} & {cmdline(cl_argv)}"


def item_speed(rep, args):
    duration = 10.0 if args.quick else FLIGHT_S
    frames = int(duration * HZ)
    runs = {a: [] for a in PATTERNS}
    pp = {a: [] for a in PATTERNS}
    alone = {a: [] for a in PATTERNS}
    cmds = {}
    work = Path(tempfile.mkdtemp(prefix="flight-", dir=BB))
    try:
        for i in range(args.repeats):
            for act, (n, b) in PATTERNS.items():
                d = work / f"{act}-{i}"
                d.mkdir()
                f = Flight(act, duration, d)
                try:
                    runs[act].append(f.run())
                except Exception as e:   # noqa: BLE001 - reported in the table
                    runs[act].append({"error": str(e)})
                cmds[f"flight_{act}"] = f"{cmdline(f.sim_argv)} & {cmdline(f.fw_argv)} & (pymavlink GCS: arm, take-off 10 m, MAV_CMD_USER_1 1 in HOLD)"
                shutil.rmtree(d, ignore_errors=True)
                # the bound: the best of 3 ping-pongs (a limit, so the least disturbed run)
                best = 0.0
                for _ in range(3):
                    r, cmds[f"pingpong_{act}"] = pingpong(frames, n, b)
                    best = max(best, r["frames_per_s"] / HZ)
                pp[act].append(best)
                r, cmds[f"sim_alone_{act}"] = sim_alone(act, duration)
                alone[act].append(r["frames_per_s"] / HZ)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    res = {}
    exp_state = set()
    for act, (n, b) in PATTERNS.items():
        ok_runs = [r for r in runs[act] if "x_realtime" in r]
        s = mmm([r["x_realtime"] for r in ok_runs])
        p = mmm(pp[act])
        pct = mmm([r["x_realtime"] / q * 100 for r, q in zip(ok_runs, pp[act])])
        for r in ok_runs:
            exp_state.add(r.get("experiment") or "not asked (no HOLD)")
        res[act] = {"closed_loop_x": s, "pingpong_x": p, "pct_of_pingpong": pct, "sim_alone_x": mmm(alone[act]),
                    "runs": runs[act]}
        errs = [r["error"] for r in runs[act] if "error" in r]
        what = f"{act}: DATA {ROWS_OUT} B out, {n} x {b} B back"
        rep.row(1, f"closed loop, --actuation {act} (x real time)", fmt(s["median"] if s else None, 0, "x"),
                spread(s) if s else "; ".join(errs)[:60],
                f"ping-pong bound {fmt(p['median'], 0, 'x')}: {fmt(pct['median'] if pct else None, 0, ' %')} of it",
                ">= 300x, >= 50 %",
                None if not s else (s["median"] >= 300 and pct["median"] >= 50), cmds.get(f"flight_{act}"))
        rep.row(1, f"  UDP ping-pong bound (best of 3 per run), {what}", fmt(p["median"], 0, "x"), spread(p), "", "", None,
                cmds.get(f"pingpong_{act}"))
    flights_with = ", ".join(sorted(exp_state))
    res["experiment_1"] = flights_with
    res["flight"] = (f"{duration:g} s simulated: arm, take-off to 10 m, hold; experiment 1 (MAV_CMD_USER_1): "
                     f"{flights_with}")
    n_done = sum(1 for a in PATTERNS for r in runs[a] if r.get("experiment_done"))
    n_all = sum(len(runs[a]) for a in PATTERNS)
    rep.row(1, "  flight flown", "take-off + hold" if "accepted" not in exp_state else "take-off, hold, exp. 1",
            "", f"experiment 1: {flights_with}; finished ('ID done') in {n_done} of {n_all} flights", "", None)
    rss = {"octo-sim": mmm([r.get("sim_rss_kb") for a in PATTERNS for r in runs[a]]),
           "octo-fw": mmm([r.get("fw_rss_kb") for a in PATTERNS for r in runs[a]])}
    res["peak_rss_kb"] = rss
    rep.data["speed"] = res
    rep.data["memory_rss"] = rss
    rep.commands.update(cmds)
    return res


# ====================================================================== item 2: step cost
def parse_callgrind(path, names):
    """Inclusive Ir and call counts of the calls to `names` (callgrind, uncompressed names)."""
    out = {n: {"calls": 0, "ir": 0} for n in names}
    lines = Path(path).read_text().splitlines()
    i = 0
    while i < len(lines):
        ln = lines[i]
        if ln.startswith("cfn="):
            name = ln[4:].strip()
            if name in out and i + 2 < len(lines) and lines[i + 1].startswith("calls="):
                calls = int(lines[i + 1].split("=", 1)[1].split()[0])
                cost = int(lines[i + 2].split()[1])
                out[name]["calls"] += calls
                out[name]["ir"] += cost
                i += 3
                continue
        i += 1
    return out


def parse_step_output(text):
    kv = {}
    for ln in text.splitlines():
        m = re.match(r"step: (\S+) (.*)$", ln)
        if m:
            kv[m.group(1)] = m.group(2).strip()
    return kv


EXP_IDS = (1, 2, 3)
EXP_NAMES = {1: "experiment 1 (rotor)", 2: "experiment 2 (validation)", 3: "experiment 3 (inertia Ixx)"}


def parse_step_events(text):
    """tests/bench/step.c's last part: (name, "step" or "tick") of each measured region, in order."""
    return re.findall(r"^step: ev (\S+) (step|tick)$", text, re.M)


# the steps that say something (tests/bench/step.c, events()): name -> what the step does
STEP_EVENTS = (
    ("param_change", "a parameter change's step (ATT_WN_RP, VEH_IXX, ID_MOT_TAU set between frames)"),
    ("origin_shift", "the plant moved its origin (1 km): re-referenced, said"),
    ("frames_missing", "frames missing (0.5 s of plant frames lost): said"),
    ("exp_abort_frames_missing", "experiment 1 aborted by frames missing: said, FAILED, mode HOLD"),
    ("exp_abort_attitude", "experiment 1 aborted at the attitude limit: said, FAILED, mode HOLD"),
    ("link_back", "the link back after 0.5 s silent: said"),
    ("link_back_landing", "the link back after more than FS_LAND_AFTER: said, landing, mode LAND"),
    ("landing", "landing steps"),
    ("landed", "touch-down: said, mode DISARMED"),
    ("takeoff", "a take-off's first step (mode TAKEOFF)"),
    ("climb", "take-off climb steps"),
    ("hold_reached", "take-off reaches HOLD: mode HOLD"),
    ("takeoff_timeout", "take-off out of NAV_TKO_TO: said, FAILED, landing, mode LAND"),
    ("landing_timeout", "landing out of NAV_LAND_TO: said, FAILED"),
)


def split_step_counts(counts, kv, events=()):
    """tests/bench/step.c's regions in order: HOLD steps, then per experiment (1, 2, 3) its
    steps each followed by its app_tick, the hover allocation, N_ALLOC allocations, the worst
    one, then the named regions of its events part (parse_step_events). None if the number of
    counts does not match what the image printed."""
    nh, ne = int(kv.get("hold_steps", 0)), int(kv.get("exp_steps", 0))
    nt = int(kv.get("exp_ticks", 0))   # 0 or ne: each experiment step followed by its app_tick
    na = int(kv.get("alloc_calls", "0").split()[0])
    if len(counts) != nh + ne + nt + 1 + na + 1 + len(events):
        return None
    base = nh + ne + nt + 1 + na + 1
    ev = {}
    for (name, kind), c in zip(events, counts[base:]):
        ev.setdefault(name, {"step": [], "tick": []})[kind].append(c)
    counts = counts[:base]
    out = {"hold": counts[:nh], "exp_by": {}, "tick_by": {}, "exp": [], "exp_tick": []}
    i = nh
    per = [(e, int(kv[f"exp_steps_{e}"])) for e in EXP_IDS if f"exp_steps_{e}" in kv] or [(1, ne)]
    for e, n in per:
        blk = counts[i:i + n * (2 if nt else 1)]
        i += len(blk)
        out["exp_by"][e] = blk[0::2] if nt else blk
        out["tick_by"][e] = blk[1::2] if nt else []
        out["exp"] += out["exp_by"][e]
        out["exp_tick"] += out["tick_by"][e]
    out["alloc_hover"] = counts[i]
    out["alloc"] = counts[i + 1:i + 1 + na]
    out["alloc_worst"] = counts[-1]
    out["regions"] = {"hold": (1, nh), "exp_first": nh + 1, "exp_last": nh + ne + nt}
    out["events"] = ev
    return out


def item_step(rep, args):
    exe = BB / ("bench-step-quick" if args.quick else "bench-step")
    res = {}
    names = ["bench_hold_step", "bench_exp_step", "bench_exp_tick", "bench_alloc_hover", "bench_alloc_call",
             "bench_alloc_worst", "bench_ev_step", "bench_ev_tick"]
    host = {}
    with tempfile.TemporaryDirectory(dir=BB) as tmp:
        cg = Path(tmp) / "callgrind.out"
        argv = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={cg}", "--compress-strings=no",
                "--compress-pos=no", str(exe)]
        if shutil.which("valgrind"):
            out = subprocess.run(argv, capture_output=True, text=True, timeout=600)
            kv = parse_step_output(out.stdout)
            if out.returncode == 0 and cg.exists():
                host = parse_callgrind(cg, names)
            res["host_output"] = kv
        else:
            kv = parse_step_output(subprocess.run([str(exe)], capture_output=True, text=True).stdout)
            res["host_output"] = kv
    host_cmd = cmdline(["valgrind", "--tool=callgrind", "--compress-strings=no", str(exe)])
    res["host_callgrind"] = host
    mean = lambda n: (host[n]["ir"] / host[n]["calls"]) if host.get(n, {}).get("calls") else None

    # Cortex-M4F: one count per measured call, in order: hold, experiment, hover allocation,
    # N_ALLOC allocations, the worst one
    m4f = {}
    elf = BB / "step-m4f.elf"
    m4_cmd = cmdline(["tests/arm/insn-count.sh", "mps2-an386", elf, ARM / "insn-count.so"])
    if args.no_arm or not elf.exists():
        res["m4f"] = None
        res["m4f_missing"] = "ARM toolchain or QEMU missing (make arm installs it as root)"
    else:
        out = subprocess.run([str(REPO / "tests/arm/insn-count.sh"), "mps2-an386", str(elf), str(ARM / "insn-count.so")],
                             capture_output=True, text=True, timeout=600, cwd=REPO)
        counts = [int(x) for x in re.findall(r"octo-count: region \d+: (\d+) instructions", out.stdout)]
        kv = parse_step_output(out.stdout)
        sp = split_step_counts(counts, kv, parse_step_events(out.stdout))
        if sp:
            m4f = {"hold": sp["hold"], "exp": sp["exp_by"].get(1, []), "exp_all": sp["exp"],
                   "alloc_hover": sp["alloc_hover"], "alloc": sp["alloc"], "alloc_worst": sp["alloc_worst"]}
            for name, v in sp["events"].items():
                m4f[f"ev_{name}"] = v["step"]
                m4f[f"ev_{name}_tick"] = v["tick"]
            if sp["exp_tick"]:
                m4f["exp_tick"] = sp["exp_tick"]
        res["m4f_output"] = kv
        res["m4f"] = {k: (mmm(v) if isinstance(v, list) else v) for k, v in m4f.items()}
        res["m4f"]["exit"] = out.returncode
    kv = res.get("m4f_output") or res.get("host_output") or {}
    exp_ok = int(kv.get("exp_steps_1", kv.get("exp_steps", 0))) > 0
    bound = kv.get("alloc_step_bound", "?")
    worst_steps = kv.get("alloc_worst_steps", "?").split()[0]

    hold = mmm(m4f.get("hold", []))
    rep.row(2, "step in HOLD, Cortex-M4F (instructions)", fmt(hold["median"] if hold else None),
            spread(hold) if hold else res.get("m4f_missing", ""),
            f"host x86-64: {fmt(mean('bench_hold_step'))} Ir/step (mean)", "<= 5,000",
            None if not hold else hold["max"] <= 5000, m4_cmd)
    ex = mmm(m4f.get("exp", []))
    rep.row(2, f"step in experiment 1 ({len(m4f.get('exp', []))} steps), M4F", fmt(ex["median"] if ex else None),
            spread(ex) if ex else ("" if exp_ok else "experiment 1 not in this build"),
            f"host x86-64: {fmt(mean('bench_exp_step'))} Ir/step (mean)" if exp_ok else "no experiment step measured",
            "<= 5,000", None if not ex else ex["max"] <= 5000, m4_cmd)
    if ex:
        e = m4f["exp"]
        q = sorted(e)[int(0.99 * (len(e) - 1))]
        big = [(i + 1, x) for i, x in enumerate(e) if x > 2 * ex["median"]]
        res["m4f"]["exp_p99"] = q
        res["m4f"]["exp_one_off"] = big
        rep.row(2, "  experiment: 99th percentile; steps over 2x the median", fmt(q),
                "", ", ".join(f"step {i}: {fmt(float(x))}" for i, x in big[:4]) or "none",
                "", None, m4_cmd)
    tk = m4f.get("exp_tick")
    if tk:
        big_t = sorted(((x, i + 1) for i, x in enumerate(tk)), reverse=True)[:2]
        rep.row(2, "  between frames: app_tick after each experiment step (experiments 1-3; not in the step), M4F",
                fmt(mmm(tk)["median"]), spread(mmm(tk)),
                "results applied, mixer rebuilt, file saved, status lines formatted: "
                + ", ".join(f"after step {i}: {fmt(float(x))}" for x, i in big_t)
                + f"; host mean {fmt(mean('bench_exp_tick'))} Ir", "(reported)", None, m4_cmd)
    al = mmm(m4f.get("alloc", []))
    n_sat = kv.get("alloc_calls", "? saturated ?").split()[-1]
    rep.row(2, f"  the step's allocation alone (mixer_step), {kv.get('alloc_calls', '?').split()[0]} demands "
            f"({n_sat} saturating), M4F",
            fmt(al["median"] if al else None), spread(al),
            f"hover demand: {fmt(m4f.get('alloc_hover'))}; host mean {fmt(mean('bench_alloc_call'))} Ir", "", None, m4_cmd)
    exact = m4f.get("alloc_worst")
    res["alloc_exact_worst_m4f"] = exact
    rep.row(2, f"  between frames: the exact allocation's worst demand ({worst_steps} of <= {bound} steps; "
            "mixer_refresh), M4F", fmt(exact), "",
            f"host x86-64: {fmt(mean('bench_alloc_worst'))} Ir; step paths: {kv.get('alloc_paths', '?')}",
            "(reported)", None, m4_cmd)
    # the steps that say something: each kind's worst step (said between frames: the app_tick after it)
    ev_max = 0
    for name, what in STEP_EVENTS:
        st, tk = mmm(m4f.get(f"ev_{name}", [])), mmm(m4f.get(f"ev_{name}_tick", []))
        if not st:
            if m4f:
                rep.row(2, f"  step that says: {what}, M4F", "n/a", "", "not measured", "<= 5,000", None, m4_cmd)
            continue
        ev_max = max(ev_max, st["max"])
        n = f"{st['n']} steps, max" if st["n"] > 1 else "1 step"
        rep.row(2, f"  step that says: {what}, M4F ({n})", fmt(st["max"]), spread(st) if st["n"] > 1 else "",
                f"between frames, the app_tick after it (says it): max {fmt(tk['max'] if tk else None)}",
                "<= 5,000", st["max"] <= 5000, m4_cmd)
    lost = mmm(m4f.get("ev_link_lost_tick", []))
    if lost:
        rep.row(2, "  between frames: the app_tick that finds the link lost (its watchdog: said there), M4F",
                fmt(lost["max"]), "", f"{lost['n']} losses", "(reported)", None, m4_cmd)
    if ev_max:
        res["m4f"]["events_max"] = ev_max
    worst = al["max"] if al else None   # the step's allocation (mixer_step): its worst call
    if hold and worst is not None:
        ctl = hold["max"] - m4f["alloc_hover"] + worst
        ea = mmm(m4f.get("exp_all", []))   # every experiment phase's steps (1-3)
        est = max(hold["max"], ea["max"] if ea else 0, ev_max) - m4f["alloc_hover"] + worst
        res["worst_step_hold_saturated_m4f"] = ctl
        res["worst_step_estimate_m4f"] = est
        rep.row(2, "  worst case: HOLD step with the step's worst allocation (max - hover alloc. + worst)", fmt(ctl), "",
                f"any step so (HOLD, experiments 1-3, the steps that say something): {fmt(est)}", "<= 5,000",
                ctl <= 5000 and est <= 5000, m4_cmd)
    step_per_build(rep, args, res)
    rep.data["step"] = res
    rep.commands["step_host"] = host_cmd
    rep.commands["step_m4f"] = m4_cmd
    return res


# The 90 Hz step per build on Cortex-M: float (hard float on M4F, soft float on M0) against
# the fixed build (OCTO_FIXED, Q formats), the same app and sequence (tests/bench/step.c).
# The M0 images (ARMv6-M code) are counted on mps2-an386: no QEMU Cortex-M0 board has RAM
# for the whole app (tests/bench/bench.mk), and the count depends on the code only
STEP_BUILDS = (("m4f", "mps2-an386"), ("m4f-fixed", "mps2-an386"), ("m0", "mps2-an386"), ("m0-fixed", "mps2-an386"))


def run_step_elf(machine_, elf):
    out = subprocess.run([str(REPO / "tests/arm/insn-count.sh"), machine_, str(elf), str(ARM / "insn-count.so")],
                         capture_output=True, text=True, timeout=1800, cwd=REPO)
    counts = [int(x) for x in re.findall(r"octo-count: region \d+: (\d+) instructions", out.stdout)]
    kv = parse_step_output(out.stdout)
    sp = split_step_counts(counts, kv, parse_step_events(out.stdout))
    if not sp:
        return {"exit": out.returncode, "error": f"{len(counts)} counts", "output": kv}
    r = {"exit": out.returncode, "hold": sp["hold"], "exp": sp["exp"], "exp_tick": sp["exp_tick"], "output": kv,
         "regions": sp["regions"]}
    for e, v in sp["exp_by"].items():
        r[f"exp{e}"] = v
    r["events"] = [c for v in sp["events"].values() for c in v["step"]]
    return r


def profile_top(machine_, elf, first, every, last, top=6):
    """tests/arm/insn-profile.sh: the top routines of the measured regions first, first + every, ...
    last, as [(share %, name)], and the command"""
    argv = ["tests/arm/insn-profile.sh", machine_, str(elf), str(first), str(every), str(last), str(top)]
    out = subprocess.run([str(REPO / argv[0])] + argv[1:], capture_output=True, text=True, timeout=1800, cwd=REPO)
    rows = re.findall(r"^\s*\d+\s+([\d.]+) %\s+(\S+)$", out.stdout, re.M)
    return [(float(p), n) for p, n in rows], cmdline(argv)


# tests/bench/step.c keeps the firmware's state in A (struct app) and M (struct mav), as a
# platform's main does; every other RAM symbol defined under tests/ belongs to the harness
# (stub HAL with its parameter "file", sensor frame, semihosting start-up).
STEP_FIRMWARE_STATE = ("A", "M")


def ram_split(elf):
    """(firmware, harness) static RAM of a step image, bytes: .data and .bss symbols by the
    source file that defines them (nm -l: the images carry debug information)"""
    out = subprocess.run(["arm-none-eabi-nm", "-l", "-S", "-t", "d", str(elf)], capture_output=True, text=True,
                         check=True).stdout
    harness = 0
    for ln in out.splitlines():
        f = ln.split()
        if len(f) >= 5 and f[2] in "bBdD" and "/tests/" in f[4] and f[3] not in STEP_FIRMWARE_STATE:
            harness += int(f[1])
    t, d, b = arm_size(elf)
    return d + b - harness, harness


def step_per_build(rep, args, res):
    builds = {}
    for v, mach in STEP_BUILDS:
        elf = BB / f"step-{v}.elf"
        cmd = cmdline(["tests/arm/insn-count.sh", mach, elf, ARM / "insn-count.so"])
        if args.no_arm or not elf.exists():
            rep.row(2, f"step per build, {v}", "n/a", "", "ARM toolchain or QEMU missing", "", None, cmd)
            continue
        r = run_step_elf(mach, elf)
        t, d, b = arm_size(elf)
        fw_ram, harness_ram = ram_split(elf)
        phases = ("hold",) + tuple(f"exp{e}" for e in EXP_IDS) + ("events", "exp_tick")
        st = {k: mmm(r.get(k, [])) for k in phases}
        builds[v] = {"steps": st, "exit": r["exit"], "flash": t + d, "ram": d + b, "error": r.get("error"),
                     "ram_firmware": fw_ram, "ram_harness": harness_ram, "regions": r.get("regions")}
        mm = lambda k: f"{fmt(st[k]['median'])} ({fmt(st[k]['max'])})" if st[k] else "n/a"
        rep.row(2, f"step per build, {v}: HOLD / exp. 1 rotor / exp. 2 validation / exp. 3 inertia / "
                "steps that say something / between frames, median (max) instr.",
                " / ".join(mm(k) for k in phases), "",
                f"image (app + core + libs): flash {fmt((t + d) / 1024, 1)} KB, static RAM {fmt((d + b) / 1024, 1)} KB "
                f"(firmware {fmt(fw_ram / 1024, 1)} KB, test harness {fmt(harness_ram / 1024, 1)} KB)"
                + (f"; {r['error']}" if r.get("error") else ""), "(reported)", None, cmd)
        if v == "m4f":
            rep.row(2, "  firmware static RAM, M4F (the step image without the test harness: app, MAVLink, "
                    "core, libs)", f"{fmt(fw_ram / 1024, 1)} KB", "",
                    f"whole image {fmt((d + b) / 1024, 1)} KB, of it test harness {fmt(harness_ram / 1024, 1)} KB "
                    "(stub HAL, frame, start-up)", "<= 32 KB", fw_ram <= 32 * 1024,
                    f"arm-none-eabi-size {elf.relative_to(REPO)}; arm-none-eabi-nm -l -S {elf.relative_to(REPO)}")
    for cpu, fl, fx in (("M0", "m0", "m0-fixed"), ("M4F", "m4f", "m4f-fixed")):
        a, b_ = builds.get(fl, {}).get("steps", {}), builds.get(fx, {}).get("steps", {})
        ratios = {}
        for k in ("hold",) + tuple(f"exp{e}" for e in EXP_IDS) + ("events", "exp_tick"):
            if a.get(k) and b_.get(k):
                ratios[k] = (a[k]["median"] / b_[k]["median"], a[k]["max"] / b_[k]["max"])
        if ratios:
            names = {"hold": "HOLD", "exp1": "exp. 1", "exp2": "exp. 2", "exp3": "exp. 3",
                     "events": "steps that say something", "exp_tick": "between frames"}
            rep.row(2, f"  {cpu}: float build / fixed build, instructions (median; max)",
                    f"{ratios['hold'][0]:.2f}x" if "hold" in ratios else "n/a", "",
                    "; ".join(f"{names[k]} {m:.2f}x; {x:.2f}x" for k, (m, x) in ratios.items()),
                    "(reported)", None, None)
            res.setdefault("float_over_fixed", {})[cpu] = ratios
    # where the fixed M0 step's instructions go: the top routines of its HOLD steps and of its
    # experiment steps (every other region: each step is followed by its app_tick)
    rg = builds.get("m0-fixed", {}).get("regions")
    if rg and not args.quick:
        elf = BB / "step-m0-fixed.elf"
        top_h, cmd_h = profile_top("mps2-an386", elf, rg["hold"][0], 1, rg["hold"][1])
        top_e, _ = profile_top("mps2-an386", elf, rg["exp_first"], 2, rg["exp_last"])
        line = lambda t: ", ".join(f"{n} {p:.0f} %" for p, n in t) or "n/a"
        rep.row(2, "  where the m0-fixed step's instructions go (top routines, share of the phase)",
                f"HOLD: {line(top_h)}", "", f"experiments 1-3: {line(top_e)}", "(reported)", None,
                cmd_h + " (HOLD; experiments: FROM " + str(rg["exp_first"]) + " EVERY 2)")
        res["m0_fixed_profile"] = {"hold": top_h, "experiments": top_e}
    res["per_build"] = builds
    estim_per_build(rep, args, res)


def estim_per_build(rep, args, res):
    """The identification's estimators alone (tests/bench/estim_step.c): where the fixed build's
    experiment step goes, and what integer arithmetic saves on M0 against soft float."""
    per = {}
    for v, mach in STEP_BUILDS:
        elf = BB / f"estim-{v}.elf"
        if args.no_arm or not elf.exists():
            continue
        out = subprocess.run([str(REPO / "tests/arm/insn-count.sh"), mach, str(elf), str(ARM / "insn-count.so")],
                             capture_output=True, text=True, timeout=600, cwd=REPO)
        counts = [int(x) for x in re.findall(r"octo-count: region \d+: (\d+) instructions", out.stdout)]
        kv = {m.group(1): m.group(2) for m in re.finditer(r"estim: (\S+) (\S+)", out.stdout)}
        n1, n2, n3, n4, n5, n6, n7, n8, n9 = (int(kv.get(k, 0)) for k in (
            "rls_1x2", "rls_2x1", "ident_rotor", "ident_inertia", "motor_id", "motor_id_solve", "imu_id", "imu_id_solve",
            "imu_id_tq"))
        if len(counts) != n1 + n2 + n3 + n4 + n5 + n6 + n7 + n8 + n9 or not n1 or not n4:
            per[v] = {"error": f"{len(counts)} counts", "exit": out.returncode}
            continue
        n123 = n1 + n2 + n3
        per[v] = {"rls_1x2": mmm(counts[:n1]), "rls_2x1": mmm(counts[n1:n1 + n2]),
                  "ident_rotor": mmm(counts[n1 + n2:n123]), "ident_inertia": mmm(counts[n123:n123 + n4]),
                  "exit": out.returncode}
        n1234 = n123 + n4
        if n5:
            per[v]["motor_id"] = mmm(counts[n1234:n1234 + n5])
        if n6:
            per[v]["motor_id_solve"] = mmm(counts[n1234 + n5:n1234 + n5 + n6])
        n6_ = n1234 + n5 + n6
        if n7:
            per[v]["imu_id"] = mmm(counts[n6_:n6_ + n7])
        if n8:
            per[v]["imu_id_solve"] = mmm(counts[n6_ + n7:n6_ + n7 + n8])
        if n9:
            per[v]["imu_id_tq"] = mmm(counts[n6_ + n7 + n8:n6_ + n7 + n8 + n9])
        cmd = cmdline(["tests/arm/insn-count.sh", mach, elf, ARM / "insn-count.so"])
        p = per[v]
        rep.row(2, f"  estimators alone, {v}: rls_update 1 param x 2 outputs / 2 x 1 / ident_rotor_update"
                " / ident_inertia_update",
                f"{fmt(p['rls_1x2']['median'])} / {fmt(p['rls_2x1']['median'])} / {fmt(p['ident_rotor']['median'])}"
                f" / {fmt(p['ident_inertia']['median'])}",
                "", f"max {fmt(p['rls_1x2']['max'])} / {fmt(p['rls_2x1']['max'])} / {fmt(p['ident_rotor']['max'])}"
                f" / {fmt(p['ident_inertia']['max'])}; "
                "the rotor experiment runs ident_rotor_update for 8 rotors per step", "(reported)", None, cmd)
        if p.get("motor_id"):
            rep.row(2, f"  motor_id per frame (step + process), {v}", fmt(p["motor_id"]["median"]), "",
                    f"max {fmt(p['motor_id']['max'])}; motor_id_solve (between frames) "
                    f"{fmt(p.get('motor_id_solve', {}).get('median'))}", "(reported)", None, cmd)
        if p.get("imu_id"):
            fixed = v.endswith("-fixed")
            rep.row(2, f"  imu_id per frame (step + process), {v}", fmt(p["imu_id"]["median"]), "",
                    f"max {fmt(p['imu_id']['max'])} (the grid's refinement, once); imu_id_solve (between frames) "
                    f"{fmt(p.get('imu_id_solve', {}).get('median'))}"
                    + ("; the step stores the frame's scalars, the process between frames is integer too (imu_id.c), "
                       "the grid's refinement and the solve float (imu_id_solve.c)"
                       if fixed else ""),
                    "<= 5,000 (IMU estimator per frame, M4F)" if v == "m4f" else "(reported)",
                    p["imu_id"]["median"] <= 5000 if v == "m4f" else None, cmd)
        if p.get("imu_id_tq"):
            rep.row(2, f"  imu_id per frame with the ESCs' torques (imu_rpm_torque), {v}",
                    fmt(p["imu_id_tq"]["median"]), "", f"max {fmt(p['imu_id_tq']['max'])} (the grid's refinement, once)",
                    "<= 5,000 (IMU estimator per frame, M4F)" if v == "m4f" else "(reported)",
                    p["imu_id_tq"]["median"] <= 5000 if v == "m4f" else None, cmd)
    for cpu, fl, fx in (("M0", "m0", "m0-fixed"), ("M4F", "m4f", "m4f-fixed")):
        a, b = per.get(fl, {}), per.get(fx, {})
        if a.get("rls_1x2") and b.get("rls_1x2"):
            rat = {k: a[k]["median"] / b[k]["median"] for k in ("rls_1x2", "rls_2x1", "ident_rotor", "ident_inertia")}
            rep.row(2, f"  {cpu}: float build / fixed build, estimators alone", f"{rat['rls_1x2']:.2f}x", "",
                    f"rls 2 x 1 {rat['rls_2x1']:.2f}x, ident_rotor_update {rat['ident_rotor']:.2f}x, "
                    f"ident_inertia_update {rat['ident_inertia']:.2f}x", "(reported)", None, None)
            per.setdefault("float_over_fixed", {})[cpu] = rat
    res["estimators"] = per


# ====================================================================== item 3: memory
def arm_size(path, total=False):
    argv = ["arm-none-eabi-size"] + (["-t"] if total else []) + [str(path)]
    out = subprocess.run(argv, capture_output=True, text=True, check=True).stdout.splitlines()
    f = (out[-1] if total else out[1]).split()
    return int(f[0]), int(f[1]), int(f[2])


def struct_sizes(obj):
    out = subprocess.run(["arm-none-eabi-nm", "-S", "-t", "d", str(obj)], capture_output=True, text=True,
                         check=True).stdout
    sizes = {}
    for ln in out.splitlines():
        f = ln.split()
        if len(f) == 4 and f[3].startswith("octo_sizeof_"):
            sizes[f[3][len("octo_sizeof_"):]] = int(f[1])
    return sizes


ENV_HEADERS = ("env_hover.h", "env_kf.h", "env_osc.h", "env_limits.h")   # the flight envelope's modules (firmware/app)


def app_core_state(sizes):
    """Core structs the app keeps (members `struct NAME x;` or `x[N]` of the structs in
    firmware/app/app.h, experiment.h and the envelope's env_*.h whose type is a core struct), as {header: [(label,
    bytes)]}. Members of a `union { ... };` share their memory: the union counts as its
    largest member (an anonymous `struct { ... };` inside it as the sum of its members)."""
    out = {}
    member = re.compile(r"^\s+struct (\w+) \w+(?:\[(\d+)\])?;")
    for h in ("app.h", "experiment.h") + ENV_HEADERS:
        try:
            text = (REPO / "firmware/app" / h).read_text()
        except OSError:
            continue
        union = None      # list of [label, bytes] alternatives while inside a union
        group = None      # [label, bytes] of an anonymous struct inside the union
        for ln in text.splitlines():
            code = ln.split("/*")[0]
            if re.match(r"^\s+union\s*\{", code):
                union, group = [], None
                continue
            if union is not None:
                if re.match(r"^\s+struct\s*\{", code):
                    group = ["", 0]
                    continue
                if re.match(r"^\s+\}\s*(?:\w+(?:\[\w+\])?)?\s*;", code):
                    if group is not None:
                        union.append(group)
                        group = None
                    else:
                        if union:
                            big = max(union, key=lambda g: g[1])
                            names = "|".join(g[0] for g in union)
                            out.setdefault(h, []).append((f"union({names})", big[1]))
                        union = None
                    continue
                m = member.match(code)
                if m and m.group(1) in sizes:
                    b_ = sizes[m.group(1)] * int(m.group(2) or 1)
                    if group is not None:
                        group[0] = f"{group[0]}+{m.group(1)}" if group[0] else m.group(1)
                        group[1] += b_
                    else:
                        union.append([m.group(1), b_])
                continue
            m = member.match(code)
            if m and m.group(1) in sizes:
                out.setdefault(h, []).append((m.group(1), sizes[m.group(1)] * int(m.group(2) or 1)))
    return out


def module_sizes(lib):
    out = subprocess.run(["arm-none-eabi-size", str(lib)], capture_output=True, text=True, check=True).stdout
    mods = {}
    for ln in out.splitlines()[1:]:
        f = ln.split()
        if len(f) >= 6:
            mods[f[5]] = int(f[0]) + int(f[1])
    return mods


def core_in_image(map_path):
    """Bytes of libcore.a's code and constants that a linked image keeps (its linker map; the
    images link with --gc-sections, so what no caller reaches is dropped): the core's share of
    a firmware's flash, as against all of libcore.a."""
    try:
        text = map_path.read_text()
    except OSError:
        return None
    i = text.find("Linker script and memory map")
    if i < 0:
        return None
    kept = re.sub(r"^ (\.\S+)\n\s+0x", r" \1 0x", text[i:], flags=re.M)   # long names wrap
    return sum(int(m.group(1), 16) for m in re.finditer(
        r"^ \.(?:text|rodata|data)\S*\s+0x[0-9a-f]+\s+0x([0-9a-f]+)\s+\S*libcore\.a\(", kept, re.M))


def core_opt(variant):
    """The core's optimisation on an ARM target: ARM_CORE_OPT_<v> of tests/arm/arm.mk, else
    the Makefile's OPT (-O2), and ARM_SETUP_OPT of its set-up objects (*_setup.o) when it
    differs."""
    try:
        mk = (REPO / "tests/arm/arm.mk").read_text()
    except OSError:
        mk = ""
    m = re.search(rf"^ARM_CORE_OPT_{re.escape(variant)}\s*\??=[ \t]*(\S*)", mk, re.M)
    s = re.search(r"^ARM_SETUP_OPT\s*\??=[ \t]*(\S*)", mk, re.M)
    opt = m.group(1) if m and m.group(1) else "-O2"
    setup = s.group(1) if s and s.group(1) else opt
    return opt + ("" if setup == opt else f", *_setup.o {setup}") + " (tests/arm/arm.mk)"


def item_memory(rep, args):
    res = {}
    if args.no_arm or not shutil.which("arm-none-eabi-size"):
        rep.row(3, "core flash / RAM on Cortex-M4F, M0", "n/a", "ARM toolchain missing", "", "< 32 KB, < 8 KB", None)
    else:
        for v in ("m4f", "m0", "m0-fixed"):
            lib = ARM / v / "libcore.a"
            if not lib.exists():
                continue
            t, d, b = arm_size(lib, total=True)
            linked = None
            base, core = ARM / v / "size-base.elf", ARM / v / "size-core.elf"
            if base.exists() and core.exists():
                bt, bd, bb = arm_size(base)
                ct, cd, cb = arm_size(core)
                linked = {"flash": (ct + cd) - (bt + bd), "ram": (cd + cb) - (bd + bb)}
            sizes = struct_sizes(ARM / v / "structs.o") if (ARM / v / "structs.o").exists() else {}
            owned = app_core_state(sizes)
            ctl = sum(n for h in ("app.h",) + ENV_HEADERS for _, n in owned.get(h, []))   # the app owns env_*
            idn = sum(n for _, n in owned.get("experiment.h", []))
            mods = module_sizes(lib)
            big = sorted(mods.items(), key=lambda kv: -kv[1])[:2]
            res[v] = {"text": t, "data": d, "bss": b, "flash": t + d, "ram": d + b, "linked": linked,
                      "modules": mods, "structs": sizes, "app_owned": owned,
                      "state_control": ctl, "state_identification": idn}
            cpu = {"m4f": "Cortex-M4F", "m0": "Cortex-M0", "m0-fixed": "Cortex-M0, fixed build"}[v]
            res[v]["opt"] = opt = core_opt(v)
            rep.row(3, f"core on {cpu}, built {opt}: .text/.data/.bss (bytes)", f"{t}/{d}/{b}", "",
                    f"{fmt((t + d) / 1024, 1)} KB: " + ", ".join(f"{k} {fmt(x / 1024, 1)}" for k, x in big)
                    + (f"; linked + libgcc/libm {fmt(linked['flash'] / 1024, 1)} KB" if linked else ""),
                    "flash < 32 KB", (t + d) < 32 * 1024,
                    f"arm-none-eabi-size -t build/arm/{v}/libcore.a")
            used = core_in_image(BB / f"step-{v}.elf.map")
            res[v]["in_firmware"] = used
            rep.row(3, f"  of it in the firmware image on {v} (B)", fmt(used), "",
                    "the core functions octo-fw's app reaches (the step bench's image: the app on a "
                    "stub HAL, --gc-sections); the rest is API that only tests call", "", None,
                    f"linker map build/bench/step-{v}.elf.map")
            rep.row(3, f"  core RAM on {v}: globals + core state in app + in experiment (B)",
                    f"{d + b} + {ctl} + {idn}", "",
                    "largest: " + ", ".join(f"{t_} {x}" for t_, x in sorted(
                        {t_: n for h in owned for t_, n in owned[h]}.items(), key=lambda kv: -kv[1])[:3]),
                    "RAM < 8 KB", (d + b + ctl + idn) < 8192, f"arm-none-eabi-nm -S build/arm/{v}/structs.o")
    rss = rep.data.get("memory_rss") or {}
    for name in ("octo-fw", "octo-sim"):
        s = rss.get(name)
        rep.row(3, f"peak resident memory of {name} (KB)", fmt(s["median"] if s else None), spread(s),
                "during item 1's flights (VmHWM)", "", None, rep.commands.get("flight_dref"))
    res["peak_rss_kb"] = rss
    rep.data["memory"] = res
    return res


# ====================================================================== item 4: allocation
def item_alloc(rep, args):
    argv = [BB / "bench-alloc", 2000 if args.quick else 20000, 1]
    r = json.loads(subprocess.run([str(a) for a in argv], capture_output=True, text=True, check=True).stdout)
    c = cmdline(argv)
    p, q = r["priority"], r["clip"]
    rep.row(4, f"attainable demands reproduced exactly ({r['attainable']} of {r['demands']})",
            fmt(p["exact_attainable_pct"], 2, " %"), "",
            f"pinv + clipping: {fmt(q['exact_attainable_pct'], 2, ' %')}", "100 %",
            p["exact_attainable_pct"] >= 100.0, c)
    ax = [("f_n", "thrust N", 3), ("tau_x_nm", "roll N m", 3), ("tau_y_nm", "pitch N m", 3), ("tau_z_nm", "yaw N m", 4)]
    rep.row(4, f"unattainable ({r['unattainable']}): mean |error| " + ", ".join(a[1] for a in ax),
            " / ".join(fmt(p["unattainable_err_mean"][k], n) for k, _, n in ax), "",
            "clip: " + " / ".join(fmt(q["unattainable_err_mean"][k], n) for k, _, n in ax), "(reported)", None, c)
    rep.row(4, "  unattainable: max |error| per axis",
            " / ".join(fmt(p["unattainable_err_max"][k], n) for k, _, n in ax), "",
            "clip: " + " / ".join(fmt(q["unattainable_err_max"][k], n) for k, _, n in ax), "", None, c)
    rep.row(4, "  allocator steps used, max over all demands", str(r["priority_max_steps"]), "",
            f"iteration bound (mixer.h): {r['step_bound']}", "(reported)", None, c)
    rep.data["alloc"] = r
    rep.commands["alloc"] = c
    return r


# ====================================================================== item 5: estimation
def chi2_interval(n):
    """95 % interval of var/CRLB for an efficient estimator over n runs (Wilson-Hilferty)."""
    k = n - 1
    q = lambda z: k * (1 - 2 / (9 * k) + z * math.sqrt(2 / (9 * k))) ** 3 / k
    return q(-1.959964), q(1.959964)


def sd2_bounds(n):
    """Where var / sd^2 (the mean of n squared errors over their sds) must lie: [0.8, 1.25], or a
    unit normal's 95 % interval of a chi-square's n dof over n where that is wider (a few accepted
    values cannot tell an sd 10 % off)."""
    lo, hi = chi2_interval(n + 1) if n > 1 else (0.0, math.inf)
    return min(0.8, lo), max(1.25, hi)


def fw_excitation():
    """octo-fw's experiment 1 excitation defaults (ID_EXC_KIND/AMP/DIV), from --dump-params."""
    d = {"ID_EXC_KIND": 1.0, "ID_EXC_AMP": 0.04, "ID_EXC_DIV": 9.0}
    try:
        out = subprocess.run([str(B / "octo-fw"), "--dump-params"], capture_output=True, text=True, timeout=10)
        for p in json.loads(out.stdout)["params"]:
            if p["name"] in d:
                d[p["name"]] = float(p["default"])
    except (OSError, ValueError, KeyError, subprocess.SubprocessError):
        pass
    return int(d["ID_EXC_KIND"]), d["ID_EXC_AMP"], int(d["ID_EXC_DIV"])


def item_estim(rep, args):
    runs = 200 if args.quick else 20000
    lo, hi = chi2_interval(runs)
    kind, amp, div = fw_excitation()
    kinds = {0: "uniform", 1: "PRBS", 2: "multisine"}
    cases = [("octo-fw exp. 1", [kind, amp, div],
              f"{kinds.get(kind, kind)} +/-{amp:g} every {div} frames ({HZ / div:g} Hz)"),
             ("paper's dither", [0, 0.05, 1], "uniform +/-0.05 every frame (the paper's delta_1)")]
    res = {"var_over_crlb_95pct_interval": [lo, hi], "cases": {}}
    for name, exc, desc in cases:
        argv = [BB / "bench-estim", runs, 1, *exc]
        r = json.loads(subprocess.run([str(a) for a in argv], capture_output=True, text=True, check=True).stdout)
        c = cmdline(argv)
        rep.commands[f"estim ({name})"] = c
        r["description"] = desc
        res["cases"][name] = r
        who = "ident" if r.get("have_ident") else "own"
        label = "ident_rotor" if who == "ident" else "filt+rls"
        for key in ("t5", "t10"):
            t = r[key]
            e, o = t[who], t["own"]
            first = key == "t5"
            if first:
                rep.row(5, f"k_f, {name}: {desc}; {runs} runs", "", "", "", "", None, c)
            rep.row(5, f"  lag-aware ({label}) at {t['seconds']:g} s: bias / std (%)",
                    f"{e['bias_pct']:+.4f} / {e['std_pct']:.4f}", "",
                    f"CRLB std {e['crlb_std_pct']:.4f} %", "|bias| < 0.1 %", abs(e["bias_pct"]) < 0.1, c)
            rep.row(5, f"    var/CRLB at {t['seconds']:g} s", f"{e['var_over_crlb']:.3f}",
                    f"95 % if efficient: [{lo:.2f} .. {hi:.2f}]",
                    f"filt.h + rls.h here: {o['var_over_crlb']:.3f}" if who == "ident" else "",
                    "[0.85, 1.2]", 0.85 <= e["var_over_crlb"] <= 1.2, c)
        p5, p10 = r["t5"]["plain"], r["t10"]["plain"]
        rep.row(5, "  paper's plain estimator (eq. 18-20): bias at 5 s / 10 s (%)",
                f"{p5['bias_pct']:+.2f} / {p10['bias_pct']:+.2f}", "",
                f"closed form {r['plain_bias_closed_form_pct']:+.2f} %", "(reference)", None, c)
    rep.data["estim"] = res
    item_motor(rep, args)
    return res


def item_motor(rep, args):
    """The joint rotor-model estimator (motor_id.h) over random vehicles (bench-motor)."""
    runs = 100 if args.quick else 1000
    argv = [BB / "bench-motor", runs, 1]
    r = json.loads(subprocess.run([str(a) for a in argv], capture_output=True, text=True, check=True).stdout)
    c = cmdline(argv)
    rep.commands["motor model"] = c
    rep.row(5, f"motor model of every rotor (lag 10-100 ms, delay 0-3, curve 0-0.5, one rotor 0.8-1); "
               f"{runs} runs each", "", "", "", "", None, c)
    for name, desc in (("curve_estimated", "curve estimated"), ("curve_known_linear", "linear rotors, curve known")):
        for sec in ("5s", "10s"):
            t = r[f"{name}_{sec}"]
            rep.row(5, f"  {desc}, {sec}: k_f bias / std (%), var / reported sd^2",
                    f"{t['kf_bias_pct']:+.3f} / {t['kf_std_pct']:.3f}, {t['kf_var_over_reported']:.2f}", "",
                    f"rejected {t['rejected_pct']:.1f} %", "|bias| < 0.1 %", abs(t["kf_bias_pct"]) < 0.1, c)
            rep.row(5, "    lag bias / std (%), delay chosen right, curve bias / std",
                    f"{t['lag_bias_pct']:+.3f} / {t['lag_std_pct']:.3f}, {t['delay_right_pct']:.1f} %, "
                    f"{t['curve_bias']:+.4f} / {t['curve_std']:.4f}", "",
                    f"accepted with a wrong delay {t['accepted_wrong_delay_pct']:.1f} %, "
                    f"a lag > 5 % off {t['accepted_lag_off_5pct']:.1f} %, "
                    f"k_f > 4 sd off {t['accepted_kf_over_4sd_pct']:.1f} %", "(reported)", None, c)
            rep.row(5, "    var / reported sd^2 of the lag, curve, scales; whiteness: false rejections, Q / dof",
                    f"{t['lag_var_over_reported']:.2f}, {t['curve_var_over_reported']:.2f}, "
                    f"{t['scale_var_over_reported']:.2f}; {t['white_rejected_pct']:.1f} %, "
                    f"{t['white_q_over_dof']:.2f}", "", "", "(reported)", None, c)
    t = r["stale_prior_10s"]
    rep.row(5, "  stale lag prior (85 ms, another vehicle's) on 10-20 ms motors, curve estimated, 10s: "
               "rejected, accepted with k_f > 4 sd off, with the lag > 5 % off",
            f"{t['rejected_pct']:.1f} %, {t['accepted_kf_over_4sd_pct']:.1f} %, {t['accepted_lag_off_5pct']:.1f} %", "",
            f"k_f bias / std of the accepted {t['kf_bias_pct']:+.3f} / {t['kf_std_pct']:.3f} %, "
            f"var / reported sd^2 {t['kf_var_over_reported']:.2f}", "(reported)", None, c)
    # the same runs (same seeds, same vehicles) with the core built fixed point: its per-frame
    # estimator in integers, the solve between frames in float
    fargv = [BB / "bench-motor-fixed", runs, 1]
    fx = json.loads(subprocess.run([str(a) for a in fargv], capture_output=True, text=True, check=True).stdout)
    fc = cmdline(fargv)
    rep.commands["motor model, fixed build"] = fc
    for sec in ("5s", "10s"):
        t, f_ = r[f"curve_estimated_{sec}"], fx[f"curve_estimated_{sec}"]
        rep.row(5, f"  fixed build (Q16.16), curve estimated, {sec}: k_f bias / std (%), lag bias / std (%), "
                   "delay chosen right",
                f"{f_['kf_bias_pct']:+.3f} / {f_['kf_std_pct']:.3f}, {f_['lag_bias_pct']:+.3f} / "
                f"{f_['lag_std_pct']:.3f}, {f_['delay_right_pct']:.1f} %", "",
                f"float build on the same runs: {t['kf_bias_pct']:+.3f} / {t['kf_std_pct']:.3f}, "
                f"{t['lag_bias_pct']:+.3f} / {t['lag_std_pct']:.3f}, {t['delay_right_pct']:.1f} %",
                "|bias| < 0.1 %", abs(f_["kf_bias_pct"]) < 0.1, fc)
    r["fixed"] = fx
    rep.data["motor"] = r


# ====================================================================== item 6: simulator
def item_sim(rep, args):
    secs = 60 if args.quick else 600
    argv = [BB / "bench-physics", secs]
    xs = []
    for _ in range(args.repeats):
        out = subprocess.run([str(a) for a in argv], capture_output=True, text=True, check=True)
        xs.append(json.loads(out.stdout))
    c = cmdline(argv)
    fps = mmm([x["frames_per_s"] for x in xs])
    rk = mmm([x["rk4_steps_per_s"] for x in xs])
    rep.row(6, "physics alone: RK4 steps (2 ms) per second", fmt(rk["median"]), spread(rk),
            f"{fmt(fps['median'])} frames/s = {fmt(fps['median'] / HZ)}x real time", "", None, c)
    sp = rep.data.get("speed", {})
    for act in PATTERNS:
        s = (sp.get(act) or {}).get("sim_alone_x")
        rep.row(6, f"  octo-sim --lockstep, tightest client, {act} (x real time)", fmt(s["median"] if s else None, 0, "x"),
                spread(s), f"ping-pong bound {fmt(sp[act]['pingpong_x']['median'], 0, 'x')}" if s else "",
                "", None, rep.commands.get(f"sim_alone_{act}"))
    rep.data["sim"] = {"physics": xs, "frames_per_s": fps, "rk4_steps_per_s": rk}
    rep.commands["physics"] = c
    return xs


# ====================================================================== item 7: octo-sil
SIL_HOVER = "arm; takeoff 10; wait hold; sleep {secs}"


def run_rusage(argv, timeout=600):
    """(wall s, peak RSS kB, stdout, stderr, status) of a child, from wait4."""
    import resource  # noqa: F401  (wait4's rusage)
    t0 = time.monotonic()
    p = subprocess.Popen([str(a) for a in argv], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE)
    timer = threading.Timer(timeout, p.kill)
    timer.start()
    try:
        out, err = p.stdout.read(), p.stderr.read()
        _pid, status, ru = os.wait4(p.pid, 0)
    finally:
        timer.cancel()
    p.returncode = os.waitstatus_to_exitcode(status)
    return time.monotonic() - t0, ru.ru_maxrss, out.decode(errors="replace"), err.decode(errors="replace"), \
        p.returncode, ru.ru_utime + ru.ru_stime


def item_sil(rep, args):
    secs = 30 if args.quick else 300
    # through build/bench/peakrss: octo-sil's own peak RSS and CPU time (ru_maxrss of a
    # child of this Python process would include the size of Python)
    sil_argv = [BB / "peakrss", B / "octo-sil", "--quiet", "--mission", SIL_HOVER.format(secs=secs)]
    phys_argv = [BB / "bench-physics", secs]
    sil_x, phys_x, ratio, rss, cpu_x = [], [], [], [], []
    for _ in range(args.repeats):
        # interleaved, so that both see the same machine
        out = subprocess.run([str(a) for a in phys_argv], capture_output=True, text=True, check=True)
        px = json.loads(out.stdout)["sim_s_per_wall_s"]
        wall, _kb, _o, err, rc, _cpu = run_rusage(sil_argv)
        m = re.search(r"stopped at t=([0-9.]+) s", err)
        pr = re.search(r"^peakrss: peak_rss_kb (\d+) cpu_s ([0-9.]+) status", err, re.M)
        if rc != 0 or not m or not pr:
            raise RuntimeError(f"octo-sil failed ({rc}): {err[-300:]}")
        kb, cpu = int(pr.group(1)), float(pr.group(2))
        sx = float(m.group(1)) / wall
        cpu_x.append(float(m.group(1)) / max(cpu, 1e-6))
        sil_x.append(sx)
        phys_x.append(px)
        ratio.append(100.0 * sx / px)
        rss.append(kb)
    sx, px, rt, mem = mmm(sil_x), mmm(phys_x), mmm(ratio), mmm(rss)
    rep.row(7, "octo-sil: simulated s per wall s (hover, app + plant + X-Plane codecs)",
            fmt(sx["median"], 0, "x"), spread(sx, 0, "x"), f"physics alone {fmt(px['median'], 0, 'x')}",
            ">= 2,000x", sx["median"] >= 2000, cmdline(sil_argv))
    cx = mmm(cpu_x)
    rep.row(7, "  octo-sil: simulated s per CPU s (user + sys; less sensitive to load)",
            fmt(cx["median"], 0, "x"), spread(cx, 0, "x"), "", "", None)
    rep.row(7, "  octo-sil / physics alone (%)", fmt(rt["median"], 0, " %"), spread(rt, 0, " %"),
            "same run, interleaved", ">= 50 %", rt["median"] >= 50)
    udp = rep.data.get("memory_rss") or {}
    fw_kb, sim_kb = ((udp.get(k) or {}).get("median") for k in ("octo-fw", "octo-sim"))
    rep.row(7, "  octo-sil peak RSS (kB)", fmt(mem["median"]), spread(mem),
            f"octo-fw {fmt(fw_kb)} + octo-sim {fmt(sim_kb)} (item 3)" if fw_kb and sim_kb else "", "", None,
            cmdline(sil_argv))
    rep.commands["sil"] = cmdline(sil_argv)
    rep.commands["sil_physics"] = cmdline(phys_argv)

    # whole missions, start-up to report, as a user runs them
    gcs = REPO / ".venv" / "bin" / "octo-gcs"
    n = 1 if args.quick else max(1, min(args.repeats, 3))
    variants = [("in-process, no plots", ["--in-process", "--no-plots"]), ("in-process, plots", ["--in-process"]),
                ("UDP, no plots", ["--no-plots"]), ("UDP, plots", [])]
    missions = {}
    with tempfile.TemporaryDirectory(prefix="octo-bench-") as tmp:
        for label, extra in variants:
            xs = []
            for i in range(n):
                argv = [gcs, "mission", "--out", Path(tmp) / f"m{i}", *extra]
                t0 = time.monotonic()
                r = subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=600,
                                   env=dict(os.environ, OCTO_BUILD=str(B)))
                xs.append(time.monotonic() - t0 if r.returncode in (0, 1) else None)
            missions[label] = mmm(xs)
    ref = missions.get("UDP, no plots")
    for label, _extra in variants:
        x = missions[label]
        rep.row(7, f"  whole mission (octo-gcs mission), {label} (s)", fmt(x["median"] if x else None, 2),
                spread(x, 2) if x else "", f"UDP no plots {fmt(ref['median'], 2)} s" if ref else "",
                "< 1 s" if label == "in-process, no plots" else "",
                (x["median"] < 1.0) if (x and label == "in-process, no plots") else None,
                cmdline([gcs, "mission", "--out", "DIR", *dict(variants)[label]]))
    rep.data["sil"] = {"sil_x": sx, "sil_cpu_x": cx, "physics_x": px, "ratio_pct": rt, "peak_rss_kb": mem, "missions_s": missions}
    return rep.data["sil"]

# ====================================================================== item 8: campaign
def item_campaign(rep, args):
    n = 4 if args.quick else 60
    res = {}
    with tempfile.TemporaryDirectory(prefix="bench-campaign-") as tmp:
        spec = Path(tmp) / "spec.json"
        spec.write_text(json.dumps({"name": "bench", "missions": n, "seed": 500, "plant": "in-process",
                                    "timeout": 600, "experiments": [6]}))
        for w in (1, 2):
            out = Path(tmp) / f"w{w}"
            argv = [B.parent / ".venv" / "bin" / "octo-gcs", "campaign", spec, "--out", out, "--workers", w]
            load0 = os.getloadavg()[0]
            subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=3600)
            doc = json.loads((out / "campaign.json").read_text())
            t = doc["throughput"]
            res[w] = {"missions_per_min": t["missions_per_min"], "missions": t["missions_this_run"],
                      "missions_s": t["missions_s"], "wall_s": t["wall_s"], "plant": t["plant"],
                      "ran": doc["ran"], "mission_wall_s_mean": t["mission_wall_s_mean"],
                      "mission_cpu_s_mean": t.get("mission_cpu_s_mean"),
                      "load_1m": [round(load0, 1), round(os.getloadavg()[0], 1)]}
            rep.commands[f"campaign ({w} worker{'s' if w > 1 else ''})"] = cmdline(
                [".venv/bin/octo-gcs", "campaign", "SPEC", "--out", "DIR", "--workers", w]) + \
                f"  (SPEC: {n} missions of the paper's vehicle, seeds 500.., experiment 6, plant in-process)"
    r1, r2 = res[1]["missions_per_min"], res[2]["missions_per_min"]
    eff = r2 / (2 * r1) if r1 and r2 else None
    c = rep.commands.get("campaign (2 workers)")
    for w in (1, 2):
        r = res[w]
        sil = "octo-sil" in r["plant"]
        rep.row(8, f"campaign, {w} local worker{'s' if w > 1 else ''}: missions per minute ({r['missions']} missions, "
                f"{r['plant']})", fmt(r["missions_per_min"], 1), "",
                f"{r['ran']} ran; a mission {fmt(r['mission_wall_s_mean'], 2, ' s')} wall, "
                f"{fmt(r['mission_cpu_s_mean'], 3, ' s')} CPU; load {r['load_1m'][0]}-{r['load_1m'][1]}",
                ">= 200 (octo-sil, 2 cores)" if w == 2 and sil else "",
                (r["missions_per_min"] or 0) >= 200 if w == 2 and sil else None,
                rep.commands.get(f"campaign ({w} worker{'s' if w > 1 else ''})"))
    cpu = [res[w]["mission_cpu_s_mean"] for w in (1, 2) if res[w]["mission_cpu_s_mean"]]
    if cpu:
        per = statistics.fmean(cpu)
        cores = os.cpu_count() or 1
        rep.row(8, f"  CPU per mission on its worker (process and children, s): {cores} idle cores would fly "
                f"{cores} x 60 / CPU missions per minute", fmt(per, 3), "",
                f"{fmt(cores * 60.0 / per, 0)} missions/min on {cores} idle cores", "", None, c)
    rep.row(8, "  scaling efficiency 1 -> 2 workers: rate(2) / (2 rate(1))",
            fmt(100 * eff if eff is not None else None, 0, " %"), "", f"{os.cpu_count()} cores, load "
            f"{os.getloadavg()[0]:.1f}", ">= 80 %", eff is not None and eff >= 0.8, c)
    rep.data["campaign"] = {"workers": res, "efficiency": eff}
    return res


# ====================================================================== item 9: per source
def item_sources(rep, args):
    """Identification per source on random vehicles (tests/bench/ident_sources.py)."""
    runs = 40 if args.quick else 1000
    argv = [sys.executable, Path(__file__).parent / "ident_sources.py", "--runs", runs, "--jobs", 2]
    r = json.loads(subprocess.run([str(a) for a in argv], capture_output=True, text=True, check=True,
                                  timeout=7200).stdout)
    c = cmdline([".venv/bin/python", "tests/bench/ident_sources.py", "--runs", runs, "--jobs", 2])
    rep.commands["identification per source"] = c
    rep.row(9, f"identification per source: experiment 6 on {runs} random vehicles (lag 10-100 ms, delay 0-3, "
               "curve 0-0.5, k_f, k_tau, inertia +/-30 %, one rotor 0.8-1), default sensor noise", "", "", "", "",
            None, c)
    names = {"thrust": "thrust rows (ID_SOURCE 1)", "imu_only": "imu (the IMU alone), rotor scales given",
             "imu": "imu_rpm (IMU + ESC speeds), rotor scales given",
             "imu_weak": "imu_rpm, the weak rotor unknown",
             "imu_tq": "imu_rpm_torque (IMU + ESC speeds and torques), rotor scales given"}
    for how, label in names.items():
        t = r[how]
        causes = ", ".join(f"{k} {v}" for k, v in sorted(t["causes"].items(), key=lambda kv: -kv[1])) or "none"
        rep.row(9, f"  {label}: not identified (k_f not accepted), with the causes",
                f"{100.0 * t['rejected'] / t['runs']:.1f} %", "", causes,
                "<= 2 %", t["rejected"] <= 0.02 * t["runs"], c)
        for k in ("kf", "ktau", "ratio", "ixx", "iyy", "izz"):
            q = t.get(k)
            if not q:
                continue
            tol = {"kf": 1.0, "ktau": 1.0, "ratio": 2.0, "ixx": 2.0, "iyy": 2.0}.get(k) if how != "thrust" else None
            within = q["within_1pct"] if tol == 1.0 else q["within_2pct"]
            # beyond max(3 sd, the quantity's tolerance: 1 % for k_f and k_tau, 2 % for the rest)
            n_beyond = len(q["beyond_3sd_and_tol"])
            lo, hi = sd2_bounds(q["accepted"])
            rep.row(9, f"    {k}: error rms / max (%), var / sd^2 (error / sd's mean square), beyond max(3 sd, tolerance)",
                    f"{q['err_rms_pct']:.2f} / {q['err_max_pct']:.2f}, {q['var_over_sd2']:.2f}, {n_beyond}",
                    "", f"{q['accepted']} accepted" + (f"; {100 * within:.1f} % within {tol:g} %" if tol else ""),
                    f"var / sd^2 in [{lo:.2f}, {hi:.2f}], 0 beyond",
                    lo <= q["var_over_sd2"] <= hi and n_beyond == 0, c)
        if t.get("lag_within_10pct") is not None:
            lag = how == "imu_only"   # the IMU alone: the lag's target too (the others read it from speeds or rows)
            rep.row(9, "    lag within 10 %, delay right", f"{100 * t['lag_within_10pct']:.1f} %, "
                    f"{100 * t['delay_right']:.1f} %", "", "",
                    ">= 99 % lag within 10 %, >= 99 % delay right" if lag else ">= 99 % delay right",
                    t["delay_right"] >= 0.99 and (not lag or t["lag_within_10pct"] >= 0.99), c)
    for how, label in (("imu_only", "imu alone"), ("imu", "imu_rpm")):
        for k, q in r.get(f"{how}_vs_thrust", {}).items():
            rep.row(9, f"  {label} vs thrust rows on the same vehicle, {k}: difference / combined sd, rms and beyond 3",
                    f"{q['rms']:.2f}, {q['beyond_3']}", "", f"{q['n']} pairs", "rms <= 1.25", q["rms"] <= 1.25, c)
    rep.data["sources"] = r


# ====================================================================== main
ITEMS = {"speed": item_speed, "step": item_step, "memory": item_memory, "alloc": item_alloc,
         "estim": item_estim, "sim": item_sim, "sil": item_sil, "campaign": item_campaign,
         "sources": item_sources}


# The page whose table `--readme` replaces: the text between its two markers
# (<!-- bench:begin ... --> and <!-- bench:end -->); the text around them is left alone.
PERF_DOC = REPO / "docs" / "performance.md"


def write_table(doc, table):
    """Replace the table between doc's bench markers with table; say what was done."""
    text = doc.read_text()
    m = re.search(r"(<!-- bench:begin[^>]*-->\n).*?(<!-- bench:end -->)", text, re.S)
    if not m:
        return f"{rel(doc)}: no <!-- bench:begin --> ... <!-- bench:end --> markers: not changed"
    doc.write_text(text[:m.end(1)] + table + text[m.start(2):])
    return f"{rel(doc)}: performance table replaced"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5, help="runs per timed figure (median, min, max)")
    ap.add_argument("--only", default="", help="comma-separated items: " + ",".join(ITEMS))
    ap.add_argument("--quick", action="store_true", help="tiny configuration (smoke test), figures meaningless")
    ap.add_argument("--no-arm", action="store_true", help="skip the Cortex-M figures")
    ap.add_argument("--out", default=str(B / "bench.json"))
    ap.add_argument("--readme", action="store_true",
                    help="also replace the table between the bench markers of " + rel(PERF_DOC))
    args = ap.parse_args()
    only = [x for x in args.only.split(",") if x] or list(ITEMS)
    bad = [x for x in only if x not in ITEMS]
    if bad:
        ap.error(f"unknown items {bad}")
    BB.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    rep = Report()
    mach = machine()
    errors = {}
    for name in ITEMS:
        if name not in only:
            continue
        try:
            ITEMS[name](rep, args)
        except Exception as e:   # noqa: BLE001 - one broken item must not hide the others
            errors[name] = f"{type(e).__name__}: {e}"
            rep.row({"speed": 1, "step": 2, "memory": 3, "alloc": 4, "estim": 5, "sim": 6, "sil": 7, "campaign": 8,
                     "sources": 9}[name],
                    f"{name}: FAILED", "n/a", "", errors[name][:80], "", False)
    dur = time.monotonic() - t0
    invoked = "make bench" if os.environ.get("MAKELEVEL") else cmdline([sys.executable, *sys.argv])
    print(f"== make bench: {mach['cpu']}, {mach['cores']} cores, load {mach['load_avg_1m']}, "
          f"{mach['date_utc']} UTC; {args.repeats} runs per timed figure (median [min, max])")
    rep.print()
    print(f"\n== commands (from the repository root; build/bench/ holds the harnesses, `make bench-tools` builds them)")
    for k, v in rep.commands.items():
        print(f"   {k}: {v}")
    print(f"== {len(rep.rows)} figures in {dur:.0f} s; written to {rel(args.out)} "
          f"(and the table as markdown: {rel(Path(args.out).with_suffix('.md'))})")
    doc = {"command": invoked, "argv": sys.argv[1:], "machine": mach, "repeats": args.repeats,
           "quick": args.quick, "duration_s": round(dur, 1), "rows": rep.rows, "items": rep.data,
           "commands": rep.commands, "errors": errors}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(args.out).with_suffix(".json.tmp")
    tmp.write_text(json.dumps(doc, indent=1, default=str) + "\n")
    tmp.replace(args.out)
    md = Path(args.out).with_suffix(".md")
    md.write_text(f"`{invoked}` on {mach['cpu']}, {mach['cores']} cores (load {mach['load_avg_1m']}), "
                  f"{mach['date_utc']} UTC, {dur:.0f} s; timed figures: median of {args.repeats} runs "
                  f"[min .. max].\n\n" + rep.markdown())
    if args.readme:
        print("== " + write_table(PERF_DOC, md.read_text()))
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
