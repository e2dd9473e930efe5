"""``octo-gcs mission --in-process``: the same mission flown in octo-sil.

octo-sil links octo-fw's app and octo-sim's plant into one lockstep process; the
ground station's part runs inside it as --mission steps on simulated time
(the same MAVLink commands, packed and handed to the app's MAVLink handler). The
run is deterministic: the same options give the same logs and the same report.
The parameters come from octo-sil's parameter file (written by the firmware)
instead of MAVLink; the report, the checks and the exit status are those of the
UDP mission (mission.py), and so is the staging of DIR.
"""

import functools
import json
import os
import struct
import subprocess
import sys
import threading
import time

from . import paramfile, procs
from .base import GcsError

TAKEOFF_M = 10.0
WALL_LIMIT_S = 600.0   # octo-sil flies a mission in well under a second


class WallLimit(GcsError):
    """octo-sil ran past its wall-clock limit and was stopped."""


def f32(x):
    return struct.unpack("<f", struct.pack("<f", float(x)))[0]


def firmware_defaults(build):
    """{NAME: default} of octo-fw's parameter table (octo-sil starts from it)."""
    try:
        out = subprocess.run([str(build / "octo-fw"), "--dump-params"], capture_output=True, text=True,
                             timeout=30, check=True).stdout
        return {p["name"]: f32(p["default"]) for p in json.loads(out)["params"]}
    except (OSError, subprocess.SubprocessError, ValueError, KeyError) as e:
        raise GcsError(f"cannot read octo-fw's parameter table (octo-fw --dump-params): {e}") from None


def mission_text(bench, experiments):
    steps = [f"param {k} {v!r}" for k, v in bench.items()]
    steps += ["arm", f"takeoff {TAKEOFF_M:g}", "wait hold"]
    for e in experiments:
        steps += [f"experiment {e}", "wait experiment"]
    steps += ["land", "wait disarmed"]
    return "\n".join(steps) + "\n"


def fly(build, args, veh, experiments, stage, prog):
    """Runs octo-sil; returns (nominal, after, texts, wall seconds)."""
    from .identify import planned_sim_seconds

    nominal = firmware_defaults(build)
    bench = {"VEH_MASS": veh["mass"], "VEH_ARM_L": veh["arm_length"]}
    if "ID_SEED" in nominal:
        bench["ID_SEED"] = float(args.seed)
    for name, value in args.param_values.items():
        if name not in nominal:
            raise GcsError(f"--param {name}: the vehicle has no such parameter")
        bench[name] = value
    nominal.update({k: f32(v) for k, v in bench.items()})
    planned = sum(planned_sim_seconds(nominal, e) for e in experiments) if experiments else 0.0
    (stage / "mission.txt").write_text(mission_text(bench, experiments))
    argv = [build / "octo-sil", "--seed", args.seed, "--xplane-version", args.xplane_version,
            "--params", stage / "fw-storage.parm", "--lcm-fw", f"file://{stage / 'fw.lcm'}",
            "--lcm-sim", f"file://{stage / 'truth.lcm'}", "--duration", max(300.0, 3 * planned + 200.0),
            "--mission", stage / "mission.txt"]
    if args.vehicle:
        argv += ["--vehicle", os.path.abspath(args.vehicle)]
    limit = getattr(args, "wall_limit", None) or WALL_LIMIT_S
    t0 = time.monotonic()
    with open(stage / "octo-sil.log", "wb") as log:
        proc = subprocess.Popen([str(a) for a in argv], stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL)
        # a watchdog instead of wait(timeout), which polls in sleeps of up to 50 ms
        expired = threading.Event()

        def kill():
            expired.set()
            proc.kill()

        timer = threading.Timer(limit, kill)
        timer.start()
        try:
            rc = proc.wait()
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        finally:
            timer.cancel()
    if expired.is_set():
        raise WallLimit(f"octo-sil still running after {limit:g} s wall: stopped")
    wall = time.monotonic() - t0
    text = (stage / "octo-sil.log").read_text(errors="replace")
    if rc != 0:
        lines = [ln for ln in text.splitlines() if ln.startswith("octo-sil:")]
        why = next((ln for ln in lines if "mission step" in ln or "not completed" in ln), None)
        raise GcsError(f"octo-sil exited with status {rc}: "
                       + (why or "\n".join(text.splitlines()[-12:])))
    prog.say(f"flight done in octo-sil: {wall:.2f} s wall")
    if not experiments and not (stage / "fw-storage.parm").exists():
        # no experiment, so no result the firmware had to store: its parameters are the
        # defaults with what the mission set
        return nominal, dict(nominal), wall
    try:
        after = {k: f32(v) for k, v in paramfile.load(stage / "fw-storage.parm").items()}
    except (OSError, paramfile.ParamFileError) as e:
        raise GcsError(f"octo-sil's parameter file: {e}") from None
    return nominal, after, wall


def run(args):
    """The command (``octo-gcs mission --in-process``): output on stdout, exit status 0 or 1."""
    return execute(args, sys.stdout, sys.stderr)


def mission(argv, stream, wall_limit=None):
    """One in-process mission inside the calling Python process: `argv` are the words that
    follow ``octo-gcs mission`` (parsed by the command's own parser, so with its defaults),
    everything the command would print goes to `stream`. octo-sil still runs as a child
    process, stopped after `wall_limit` seconds (WallLimit). Returns the exit status the
    command would have (0 pass, 1 fail); raises GcsError where the command exits 1 with a
    message (the files of the failed run are kept in OUT/failed-run/ as by the command)."""
    args = _parser().parse_args(["mission", *map(str, argv)])
    if not args.in_process:
        raise GcsError("octo_gcs.inprocess.mission flies --in-process missions only")
    args.wall_limit = wall_limit
    return execute(args, stream, stream)


@functools.lru_cache(maxsize=1)
def _parser():
    """octo-gcs's parser, built once per process (a campaign worker flies many missions)."""
    from .cli import build_parser
    return build_parser()


def execute(args, stream, err_stream):
    """The in-process mission of parsed `args`: progress, table and verdict on `stream`;
    returns 0 (pass) or 1 (failed checks); raises GcsError with the reason otherwise."""
    from .identify import merge_text_results
    from .logs import Logs
    from .mission import _keep_failed, _publish, prepare
    from .progress import Progress
    from .report import build_report, table_text, write_outputs

    t_start = time.monotonic()
    prog = Progress(stream=stream)
    if args.realtime:
        raise GcsError("--in-process runs lockstep only (octo-sil): --realtime needs the UDP mission")
    build = procs.build_dir(args.build_dir)
    if not os.access(build / "octo-sil", os.X_OK):
        raise GcsError(f"{build / 'octo-sil'} not found: run `make` first, or give --build-dir")
    experiments, veh, build, out, stage = prepare(args)
    vname = f"vehicle {args.vehicle}" if args.vehicle else "the paper's vehicle"
    prog.say(f"mission in-process: octo-sil (X-Plane {args.xplane_version}, seed {args.seed}, {vname}) "
             f"from {build}")
    ok = False
    try:
        nominal, after, _wall = fly(build, args, veh, experiments, stage, prog)
        wall_flight = time.monotonic() - t_start
        paths = [stage / "truth.lcm", stage / "fw.lcm"]
        logs = Logs([p for p in paths if p.exists()])
        texts = [text for _t, _sev, text in logs.events if text.startswith("ID")]
        after, from_texts = merge_text_results(after, texts)
        params_only = {k: after[k] for k in after if k not in from_texts}
        paramfile.save(stage / "params.parm", params_only)
        if (stage / "fw-storage.parm").exists():
            os.unlink(stage / "fw-storage.parm")   # the firmware's own storage: params.parm says it
        os.unlink(stage / "mission.txt")
        rep = build_report(stage, veh, args, nominal, after, experiments, wall_flight_s=wall_flight, logs=logs,
                           from_texts=from_texts)
        rep["run"]["plant"] = "octo-sil (in-process, lockstep)"
        write_outputs(stage, rep, args.plots)
        rep["timing"]["wall_total_s"] = round(time.monotonic() - t_start, 2)
        files = _publish(stage, out, rep)
        ok = True
    except GcsError as e:
        dest = _keep_failed(stage, out)
        raise type(e)(f"{e}" + (f"\n(the logs of the failed run are in {dest}/)" if dest else "")) from None
    finally:
        if not ok:
            dest = _keep_failed(stage, out)
            if dest:
                print(f"octo-gcs: the logs of the failed run are in {dest}/", file=err_stream)
    print(file=stream)
    print(table_text(rep), file=stream)
    print(file=stream)
    verdict = "PASS" if rep["pass"] else "FAIL"
    print(f"{verdict}: {len(files)} files in {out}/ ({', '.join(files)}); "
          f"{rep['timing']['wall_total_s']:.2f} s", file=stream)
    for c in rep["checks"]:
        if not c["ok"]:
            print(f"  {'warning' if c['warning_only'] else 'failed'}: {c['check']}: {c['detail']}", file=stream)
    return 0 if rep["pass"] else 1
