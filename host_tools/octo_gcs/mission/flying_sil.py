"""The flight in octo-sil (plant "sil"): firmware and plant in one lockstep process.

octo-sil links octo-fw's app and octo-sim's plant into one process; the ground station's part
runs inside it as a script of steps on simulated time (the same MAVLink commands, packed and
handed to the app's MAVLink handler). The run is deterministic: the same options give the same
logs and the same report. The parameters come from octo-sil's parameter file (written by the
firmware) instead of MAVLink, the identification results from the firmware's log (fw.lcm).
"""

import json
import os
import subprocess
import threading
import time

from .. import id_results, paramfile
from ..base import GcsError, f32
from ..experiments import planned_total
from .flown import Flown
from .options import TAKEOFF_M, firmware_program, plant_flags, plant_words, sil_program

WALL_LIMIT_S = 600.0  # octo-sil flies a mission in well under a second


class WallLimit(GcsError):
    """octo-sil ran past its wall-clock limit and was stopped."""


def firmware_defaults(build, program="octo-fw"):
    """{NAME: default} of the firmware's parameter table (octo-sil starts from octo-fw's, octo-sil-fixed
    from octo-fw-fixed's)."""
    try:
        out = subprocess.run(
            [str(build / program), "--dump-params"], capture_output=True, text=True, timeout=30, check=True
        ).stdout
        return {p["name"]: f32(p["default"]) for p in json.loads(out)["params"]}
    except (OSError, subprocess.SubprocessError, ValueError, KeyError) as e:
        raise GcsError(f"cannot read {program}'s parameter table ({program} --dump-params): {e}") from None


def script_text(bench, experiments):
    """octo-sil's steps: the parameters, take-off and hold, each experiment, landing."""
    steps = [f"param {k} {v!r}" for k, v in bench.items()]
    steps += ["arm", f"takeoff {TAKEOFF_M:g}", "wait hold"]
    for e in experiments:
        steps += [f"experiment {e}", "wait experiment"]
    steps += ["land", "wait disarmed"]
    return "\n".join(steps) + "\n"


def sil_argv(build, opts, stage, duration):
    """octo-sil's (or octo-sil-fixed's) command line (its steps in stage/mission.txt)."""
    argv = [
        build / sil_program(opts),
        "--seed",
        opts.seed,
        "--xplane-version",
        opts.xplane_version,
        "--params",
        stage / "fw-storage.parm",
        "--lcm-fw",
        f"file://{stage / 'fw.lcm'}",
        "--lcm-sim",
        f"file://{stage / 'truth.lcm'}",
        "--duration",
        duration,
        "--script",
        stage / "mission.txt",
    ]
    if opts.vehicle:
        argv += ["--vehicle", os.path.abspath(opts.vehicle)]
    return argv + plant_flags(opts)


def _run_limited(argv, log_path, limit):
    """Runs argv, its output into log_path, killed after `limit` wall seconds; returns its exit
    status. A watchdog instead of wait(timeout), which polls in sleeps of up to 50 ms."""
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(
            [str(a) for a in argv], stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL
        )
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
        raise WallLimit(f"{os.path.basename(str(argv[0]))} still running after {limit:g} s wall: stopped")
    return rc


def _bench(opts, veh, nominal):
    bench = {"VEH_MASS": veh["mass"], "VEH_ARM_L": veh["arm_length"]}
    if "ID_SEED" in nominal:
        bench["ID_SEED"] = float(opts.seed)
    for name, value in opts.params.items():
        if name not in nominal:
            raise GcsError(f"--param {name}: the vehicle has no such parameter")
        bench[name] = value
    return bench


def describe(opts, staged):
    vname = f"vehicle {opts.vehicle}" if opts.vehicle else "the paper's vehicle"
    return (
        f"mission in-process: {sil_program(opts)} (X-Plane {opts.xplane_version}, seed {opts.seed}, {vname}"
        f"{plant_words(opts)}) from {staged.build}"
    )


def check_build(opts):
    """octo-sil (octo-sil-fixed) and the firmware whose parameter table it starts from are there
    (before anything is staged)."""
    from .. import procs

    build = procs.build_dir(opts.build_dir)
    for name in (sil_program(opts), firmware_program(opts)):
        if not os.access(build / name, os.X_OK):
            raise GcsError(f"{build / name} not found: run `make` first, or give --build-dir")


def fly(opts, staged, prog):
    """Runs octo-sil; returns Flown (its logs in the stage are read for the results)."""
    from ..logs import Logs

    build, stage = staged.build, staged.stage
    nominal = firmware_defaults(build, firmware_program(opts))
    bench = _bench(opts, staged.vehicle, nominal)
    nominal.update({k: f32(v) for k, v in bench.items()})
    duration = max(300.0, 3 * planned_total(nominal, opts.experiments) + 200.0)
    (stage / "mission.txt").write_text(script_text(bench, opts.experiments))
    t0 = time.monotonic()
    rc = _run_limited(
        sil_argv(build, opts, stage, duration), stage / "octo-sil.log", opts.wall_limit or WALL_LIMIT_S
    )
    wall = time.monotonic() - t0
    if rc != 0:
        text = (stage / "octo-sil.log").read_text(errors="replace")
        lines = [ln for ln in text.splitlines() if ln.startswith("octo-sil")]
        why = next((ln for ln in lines if "mission step" in ln or "not completed" in ln), None)
        raise GcsError(
            f"{sil_program(opts)} exited with status {rc}: " + (why or "\n".join(text.splitlines()[-12:]))
        )
    prog.say(f"flight done in {sil_program(opts)}: {wall:.2f} s wall")
    if not opts.experiments and not (stage / "fw-storage.parm").exists():
        # no experiment, so no result the firmware had to store: its parameters are the
        # defaults with what the mission set
        after = dict(nominal)
    else:
        try:
            after = {k: f32(v) for k, v in paramfile.load(stage / "fw-storage.parm").items()}
        except (OSError, paramfile.ParamFileError) as e:
            raise GcsError(f"octo-sil's parameter file: {e}") from None
    os.unlink(stage / "mission.txt")
    if (stage / "fw-storage.parm").exists():
        os.unlink(stage / "fw-storage.parm")  # the firmware's own storage: params.parm says it
    paths = [p for p in (stage / "truth.lcm", stage / "fw.lcm") if p.exists()]
    logs = Logs(paths) if paths else None
    records = logs.id_results if logs is not None else []
    after, filled = id_results.merge(after, records)
    return Flown(nominal, after, records, filled, f"{sil_program(opts)} (in-process, lockstep)", logs)
