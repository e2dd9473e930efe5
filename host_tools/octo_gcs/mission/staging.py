"""A mission's output directory: nothing half-written is ever left in it.

The run works in DIR/.tmp-<pid>/ and moves the finished files into DIR at the end (report.md
and report.json last). A failed run leaves its logs in DIR/failed-run/ instead (with, for the
UDP plant, a report.md / report.json that name the phase that failed and why).
"""

import json
import os
import shutil
from pathlib import Path

from .. import procs, vehiclefile
from ..atomicfile import atomic_write
from ..base import GcsError

OUTPUTS = (
    "report.md",
    "report.json",
    "params.parm",
    "truth.lcm",
    "fw.lcm",
    "octo-sim.log",
    "octo-fw.log",
    "octo-sil.log",
    "fig5_excitation.png",
    "fig6_validation.png",
    "fig7_rates.png",
    "convergence.png",
)


class Staged:
    """What a mission checks and sets up first: the vehicle file, the build directory, DIR and
    a fresh staging directory in it."""

    def __init__(self, vehicle, build, out, stage):
        self.vehicle, self.build, self.out, self.stage = vehicle, build, out, stage


def prepare(opts):
    """Staged of MissionOptions `opts`. Raises GcsError naming the input."""
    try:
        veh = vehiclefile.load(opts.vehicle)
    except vehiclefile.VehicleFileError as e:
        raise GcsError(str(e)) from None
    build = procs.build_dir(opts.build_dir)
    out = Path(opts.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        stage = Path(out / f".tmp-{os.getpid()}")
        if stage.exists():
            shutil.rmtree(stage)
        stage.mkdir()
    except OSError as e:
        raise GcsError(f"cannot write {out}: {e.strerror}") from None
    return Staged(veh, build, out, stage)


def publish(stage, out, report_json):
    """Moves the finished files into DIR, reports last; removes the stage. report_json(files)
    gives report.json's text for the list of files. Returns the files' names in DIR."""
    files = sorted({p.name for p in stage.iterdir() if p.is_file()} | {"report.json"})
    atomic_write(stage / "report.json", report_json(files))
    names = sorted(p.name for p in stage.iterdir() if p.is_file())
    last = ["report.json", "report.md"]
    order = [n for n in names if n not in last] + [n for n in last if n in names]
    for n in order:
        os.replace(stage / n, out / n)
    shutil.rmtree(stage, ignore_errors=True)
    # what an earlier run left and this one did not write would not belong to this report
    for n in OUTPUTS:
        if n not in order and (out / n).exists():
            os.unlink(out / n)
    shutil.rmtree(out / "failed-run", ignore_errors=True)
    return order


def keep_failed(stage, out):
    """Moves a failed run's stage to DIR/failed-run (replacing an older one); returns it."""
    if stage is None or not stage.exists():
        return None
    dest = out / "failed-run"
    try:
        if dest.exists():
            shutil.rmtree(dest)
        os.replace(stage, dest)
        return dest
    except OSError:
        shutil.rmtree(stage, ignore_errors=True)
        return None


def failure_report(stage, opts, reason, phase, vehicle_errors, texts):
    """report.md / report.json of a failed run: the phase, the reason, the vehicle's error
    texts and every status text, the files kept (written atomically)."""
    if stage is None or not stage.exists():
        return
    files = sorted(p.name for p in stage.iterdir() if p.is_file())
    first = reason.splitlines()[0] if reason else "unknown"
    rep = {
        "pass": False,
        "failed_phase": phase,
        "failure": first,
        "failure_detail": reason,
        "vehicle_errors": vehicle_errors,
        "statustexts": texts,
        "seed": opts.seed,
        "vehicle_file": str(opts.vehicle) if opts.vehicle else None,
        "files": sorted(set(files) | {"report.md", "report.json"}),
    }
    md = [f"# Mission FAILED in phase: {phase}", "", f"**Reason:** {first}", ""]
    if len(reason.splitlines()) > 1:
        md += ["```", *reason.splitlines()[1:], "```", ""]
    if vehicle_errors:
        md += ["## Errors reported by the vehicle", "", *[f"- {t}" for t in vehicle_errors], ""]
    md += [
        "## Status texts",
        "",
        *[f"- {t}" for t in texts],
        "",
        "## Files",
        "",
        *[f"- {f}" for f in rep["files"]],
        "",
    ]
    try:
        atomic_write(stage / "report.json", json.dumps(rep, indent=2) + "\n")
        atomic_write(stage / "report.md", "\n".join(md))
    except OSError:
        pass
