"""A whole mission: MissionOptions -> staged directory -> flight -> report -> published DIR.

Progress, the table and the verdict go to `stream`; the exit status is 0 when every check
passes, 1 when one fails; a mission that cannot finish raises GcsError with the reason (its
files kept in DIR/failed-run/).
"""

import sys
import time

from .. import paramfile, procs
from ..base import GcsError
from ..progress import Progress
from . import flying_sil, flying_udp, staging
from .report import build_report, dumps, table_text, write_outputs


def _plant(opts):
    return flying_sil if opts.plant == "sil" else flying_udp


def run(opts, stream=None, err_stream=None):
    """Flies the mission of MissionOptions `opts`; returns the exit status (0 pass, 1 fail)."""
    stream = stream if stream is not None else sys.stdout
    err_stream = err_stream if err_stream is not None else sys.stderr
    plant = _plant(opts)
    t_start = time.monotonic()
    prog = Progress(stream=stream)
    if opts.plant == "sil":
        flying_sil.check_build(opts)
    staged = staging.prepare(opts)
    prog.say(plant.describe(opts, staged))
    ok = False
    try:
        with procs.signals_as_exceptions():
            flown = plant.fly(opts, staged, prog)
            wall_flight = time.monotonic() - t_start
            if opts.plant == "udp":
                prog.say(f"flight done in {wall_flight:.1f} s; building the report")
            rep = _report(opts, staged, flown, wall_flight)
            rep["timing"]["wall_total_s"] = round(time.monotonic() - t_start, 2)
            files = staging.publish(staged.stage, staged.out, lambda names: dumps(dict(rep, files=names)))
            rep["files"] = files
            ok = True
    except GcsError as e:
        if isinstance(e, flying_udp.FlightFailed):
            staging.failure_report(staged.stage, opts, str(e), e.phase, e.vehicle_errors, e.texts)
        dest = staging.keep_failed(staged.stage, staged.out)
        cls = GcsError if isinstance(e, flying_udp.FlightFailed) else type(e)
        raise cls(f"{e}" + (f"\n(the logs of the failed run are in {dest}/)" if dest else "")) from None
    finally:
        if not ok:
            dest = staging.keep_failed(staged.stage, staged.out)
            if dest:
                print(f"octo-gcs: the logs of the failed run are in {dest}/", file=err_stream)
    return _verdict(rep, files, staged.out, stream, 2 if opts.plant == "sil" else 1)


def _report(opts, staged, flown, wall_flight):
    """params.parm, report.md and the figures into the stage; returns the report."""
    stage = staged.stage
    paramfile.save(stage / "params.parm", flown.params_only)
    if (stage / "fw-storage.parm").exists():
        (stage / "fw-storage.parm").unlink()  # octo-fw's own storage: params.parm says it
    rep = build_report(
        stage,
        staged.vehicle,
        opts,
        flown.nominal,
        flown.after,
        opts.experiments,
        wall_flight_s=wall_flight,
        logs=flown.logs,
        filled=flown.filled,
        results=flown.results,
    )
    rep["run"]["plant"] = flown.plant
    write_outputs(stage, rep, opts.plots)
    return rep


def _verdict(rep, files, out, stream, digits):
    print(file=stream)
    print(table_text(rep), file=stream)
    print(file=stream)
    verdict = "PASS" if rep["pass"] else "FAIL"
    print(
        f"{verdict}: {len(files)} files in {out}/ ({', '.join(files)}); "
        f"{rep['timing']['wall_total_s']:.{digits}f} s",
        file=stream,
    )
    for c in rep["checks"]:
        if not c["ok"]:
            print(
                f"  {'warning' if c['warning_only'] else 'failed'}: {c['check']}: {c['detail']}", file=stream
            )
    return 0 if rep["pass"] else 1
