#!/usr/bin/env python3
"""bench.py - every control step of a processor-in-the-loop flight, counted (make pil-bench).

For each build (float, fixed) it flies octo-gcs mission (make run's mission unless
--experiments says otherwise) with the board of build/pil[-fixed]/ and OCTO_PIL_COUNTS set, so
that QEMU's instruction-counting plugin (tests/arm/insn_count.c) counts each app_on_frame()
between the board's step markers. Count N belongs to the log's OCTO_FW_FRAME record N (the
board sends one record per frame, after its step), whose mode (the mode after the step) and
experiment phase label it. Prints per mode: steps, median, p99, max; the image's flash
(.text + .data) and static RAM (.data + .bss, without the stack) from arm-none-eabi-size; and
the step's instructions as a share of one frame of a 168 MHz Cortex-M4F at 90 Hz (1,866,667
cycles), counting one cycle per instruction (a lower bound: loads, branches and divides take
more). Writes OUT/bench.json and keeps each flight's report in OUT/<build>/.

    tests/pil/bench.py [--builds "float fixed"] [--build build] [--out out/pil/bench]
                       [--experiments LIST] [--limit N]
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
MODES = {0: "DISARMED", 1: "IDLE", 2: "TAKEOFF", 3: "HOLD", 4: "EXPERIMENT", 5: "LAND"}
FRAME_CYCLES = 168e6 / 90.0


def percentile(sorted_vals, p):
    """Nearest-rank percentile of an ascending list."""
    if not sorted_vals:
        return None
    k = max(0, min(len(sorted_vals) - 1, int(-(-p * len(sorted_vals) // 100)) - 1))
    return sorted_vals[k]


def read_counts(path):
    out = []
    for line in Path(path).read_text().splitlines():
        if line.startswith("octo-count: region ") and line.endswith(" instructions"):
            out.append(int(line.split()[-2]))
    return out


def read_frames(path, gen_python):
    sys.path.insert(0, str(gen_python))
    sys.path.insert(0, str(REPO / "host_tools"))
    from octo import fw_frame_t
    from octo_gcs.logs import read_events
    return [fw_frame_t.decode(d) for (ch, _u, d) in read_events(str(path)) if ch == "OCTO_FW_FRAME"]


def sizes(elf):
    out = subprocess.run(["arm-none-eabi-size", str(elf)], capture_output=True, text=True, check=True).stdout
    text, data, bss = (int(x) for x in out.splitlines()[1].split()[:3])
    return {"text": text, "data": data, "bss": bss, "flash": text + data, "static_ram": data + bss}


def stats(vals):
    v = sorted(vals)
    return {"steps": len(v), "median": percentile(v, 50), "p99": percentile(v, 99), "max": v[-1] if v else None}


def fly(build, bdir, out, experiments, extra):
    counts = out / f"{build}-counts.txt"
    if counts.exists():
        counts.unlink()
    env = dict(os.environ, OCTO_PIL_COUNTS=str(counts))
    cmd = [str(REPO / ".venv/bin/octo-gcs"), "mission", "--build-dir", str(bdir), "--out", str(out / build),
           "--no-plots"]
    if experiments is not None:
        cmd += ["--experiments", experiments]
    cmd += extra
    print(f"== pil-bench: {build}: {' '.join(cmd[1:])}", flush=True)
    t0 = time.monotonic()
    rc = subprocess.run(cmd, env=env).returncode
    return rc, counts, time.monotonic() - t0


def analyse(counts_path, frames):
    counts = read_counts(counts_path)
    # the last step may be counted and its record not sent when QEMU is stopped between them
    if not 0 <= len(counts) - len(frames) <= 1:
        raise SystemExit(f"pil-bench: {len(counts)} counted steps but {len(frames)} log records: "
                         "they must pair one to one")
    counts = counts[:len(frames)]
    groups = {}
    worst = None
    for i, (c, f) in enumerate(zip(counts, frames)):
        mode = MODES.get(f.mode, str(f.mode))
        keys = ["all", mode]
        if mode == "EXPERIMENT" and f.exp_id:
            keys.append(f"EXPERIMENT {f.exp_id} phase {f.exp_phase}")
        for k in keys:
            groups.setdefault(k, []).append(c)
        if worst is None or c > worst["instructions"]:
            worst = {"instructions": c, "frame": i + 1, "t_s": round(f.t, 3), "mode": mode,
                     "exp_id": int(f.exp_id), "exp_phase": int(f.exp_phase)}
    return {k: stats(v) for k, v in groups.items()}, worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--builds", default="float fixed")
    ap.add_argument("--build", default=str(REPO / "build"))
    ap.add_argument("--out", default=str(REPO / "out/pil/bench"))
    ap.add_argument("--experiments", default=None, help="octo-gcs mission --experiments (default: its own, 6)")
    ap.add_argument("mission_args", nargs="*", help="more octo-gcs mission options (after --)")
    a = ap.parse_args()
    build, out = Path(a.build), Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    result = {"frame_cycles_168mhz_90hz": round(FRAME_CYCLES), "builds": {}}
    rc_all = 0
    for b in a.builds.split():
        bdir = build / ("pil" if b == "float" else f"pil-{b}")
        elf = build / "pil-img" / f"octo-fw-{b}.elf"
        rc, counts, wall = fly(b, bdir, out, a.experiments, a.mission_args)
        # a failed mission leaves its logs in failed-run/: its steps are counted all the same
        logdir = out / b if (out / b / "fw.lcm").exists() and rc == 0 else out / b / "failed-run"
        frames = read_frames(logdir / "fw.lcm", build / "gen/python")
        groups, worst = analyse(counts, frames)
        sz = sizes(elf)
        result["builds"][b] = {"mission_rc": rc, "wall_s": round(wall, 1), "size": sz, "steps": groups,
                               "worst": worst, "elf": str(elf)}
        rc_all |= rc
        print(f"\n== {b} image {elf.name}: flash {sz['flash']:,} B (.text {sz['text']:,} + .data {sz['data']:,}), "
              f"static RAM {sz['static_ram']:,} B (.data + .bss {sz['bss']:,}; stack 64 KB besides)")
        print(f"   mission exit {rc}" + (" (FAILED: the steps it flew are counted)" if rc else "")
              + f", {wall:.0f} s wall; instructions per step (QEMU mps2-an386, counting plugin):")
        print(f"   {'mode':<26} {'steps':>6} {'median':>8} {'p99':>8} {'max':>8}  {'max / frame at 168 MHz, 90 Hz':>30}")
        order = ["all"] + [m for m in MODES.values() if m in groups] + \
            sorted((k for k in groups if k.startswith("EXPERIMENT ")), key=lambda k: [int(x) for x in k.split()[1::2]])
        for k in order:
            s = groups[k]
            print(f"   {k:<26} {s['steps']:>6} {s['median']:>8,} {s['p99']:>8,} {s['max']:>8,}  "
                  f"{100.0 * s['max'] / FRAME_CYCLES:>29.2f}%")
        print(f"   worst step: {worst['instructions']:,} instructions, frame {worst['frame']} at t={worst['t_s']} s "
              f"({worst['mode']}" + (f", experiment {worst['exp_id']} phase {worst['exp_phase']}" if worst['exp_id'] else "")
              + f"); median step {100.0 * groups['all']['median'] / FRAME_CYCLES:.2f} % of the frame")
    (out / "bench.json").write_text(json.dumps(result, indent=2) + "\n")
    print(f"\nwrote {out / 'bench.json'}")
    return 1 if rc_all else 0


if __name__ == "__main__":
    sys.exit(main())
