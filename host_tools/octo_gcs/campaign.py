"""``octo-gcs campaign SPEC.json``: Monte Carlo missions on a Dask cluster.

One Dask task is one mission, in a temporary directory on the worker: the task builds the
mission's MissionOptions (vehicle file, seed, faults, parameters) and flies it under a timeout.
With the in-process plant the mission runs inside the worker's own Python process
(octo_gcs.mission.run: no Python start-up and imports per mission); octo-sil is still a child
process, so a firmware crash or hang is isolated, stopped at the timeout and recorded. With the
UDP plant the mission runs in a child process (``python -m octo_gcs.mission.child``, its options
as JSON on stdin). The task never raises for a mission that goes wrong: a crash or a timeout
comes back as a result with its reason. A worker that dies while running a
task has the task retried by Dask (the scheduler's ``allowed-failures``, the spec's
``retries``); after that the mission is a row with the reason too.

Results reach the client as they finish (``as_completed``); each one is appended to
DIR/results.csv at once (flush and fsync), its report.json and vehicle file copied to
DIR/missions/NNNN/ (with the last lines of a failed run's program logs). The firmware's
rejection reasons and the estimates' source come from the mission's report.json (the
firmware's result records). ``--resume`` skips the missions already in results.csv. At the end
campaign_report writes campaign.json, campaign.md and the figures.

Faults are data: the mission's options carry them by the spec's names and the plant turns them
into octo-sim's (or octo-sil's) flags. The worst missions' replay command is one
``octo-gcs mission`` line (``--fault NAME=VALUE``).

For tests only: the environment variable OCTO_CAMPAIGN_MISSION, when set, replaces the mission
command (``python -m octo_gcs.mission.child``) by its words (split like a shell), e.g. a fake
mission that crashes or hangs; it reads the same options as JSON on stdin, and it always runs
as a subprocess.
"""

import csv
import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import campaign_spec
from .atomicfile import atomic_write
from .campaign_spec import SpecError
from .mission.options import MissionOptions
from .progress import Progress
from .quantities import KEYS as QUANTITIES

RATIO = "ktiz"  # results.csv's k_tau / I_z, the firmware's own (the IMU source; empty otherwise)

MISSION_ENV = "OCTO_CAMPAIGN_MISSION"
STATUSES = ("pass", "fail", "aborted", "crash", "timeout", "lost", "error")
# "aborted": the vehicle ended the mission for a reason it stated, before a report (octo-sil: a
# step of its script failed, e.g. an experiment stopped by a rotor failure); not a crash
ABORTED_RE = re.compile(r"script step \d+ '[^']*' failed.*")
RAN = ("pass", "fail")  # the mission ran to its report (its checks passed or not)
TAIL_LINES = 40
# A mission's scratch directory on its worker: the worker's pid in the name, so that the
# directories of a worker that died (SIGKILL runs no clean-up) can be told from live ones.
TMP_PREFIX = "octo-campaign-"
TMP_RE = re.compile(rf"^{TMP_PREFIX}(\d+)-\d+-")


class CampaignError(Exception):
    def __init__(self, msg, status=1):
        super().__init__(msg)
        self.status = status


# ---------------------------------------------------------------- the task (runs on a worker)
def mission_command(override=None):
    """The words that start a mission in a child process on this machine (its options as JSON
    on stdin)."""
    if override:
        return shlex.split(override)
    return [sys.executable, "-m", "octo_gcs.mission.child"]


def mission_options(job, tmp):
    """The MissionOptions of a job in its directory `tmp` (holding vehicle.json)."""
    return MissionOptions(
        plant="sil" if job["in_process"] else "udp",
        vehicle=str(tmp / "vehicle.json"),
        seed=job["seed"],
        out=str(tmp / "out"),
        plots=False,
        experiments=list(job["experiments"]),
        params=dict(job["params"]),
        faults=dict(job["faults"]),
        build=job.get("build", "float"),
        sensors=job.get("sensors"),
    )


def _stop_group(p):
    """SIGTERM to the mission's process group (it stops its programs), SIGKILL after 10 s."""
    for sig, wait in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(p.pid, sig)
        except ProcessLookupError:
            return
        try:
            p.wait(timeout=wait)
            return
        except subprocess.TimeoutExpired:
            continue


def _tail(path, n=TAIL_LINES):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read().splitlines()[-n:]
    except OSError:
        return []


def _mission_in_worker(opts, log, timeout):
    """An in-process mission in this (the worker's) Python process, octo-sil its child process
    stopped after `timeout` s: what ``octo-gcs mission`` would print goes to `log`, its error line
    included. Returns (exit status as the command's, timed out)."""
    from .atomicfile import scratch
    from .base import GcsError
    from .mission.flying_sil import WallLimit
    from .mission.run import run

    opts.wall_limit = timeout
    with open(log, "w", encoding="utf-8") as out:
        try:
            with scratch():  # the mission's directory goes away after the task
                return run(opts, out, out), False
        except WallLimit as e:
            print(f"octo-gcs: {e}", file=out)
            return 1, True
        except GcsError as e:
            print(f"octo-gcs: {e}", file=out)
            return 1, False


def _mission_subprocess(cmd, opts, log, cwd, timeout):
    """A mission in a child process (its own process group), its options as JSON on stdin,
    stopped after `timeout` s. Returns (exit status, timed out)."""
    with open(log, "wb") as out:
        p = subprocess.Popen(
            cmd, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.PIPE, cwd=cwd, start_new_session=True
        )
        try:
            try:
                p.stdin.write(json.dumps(opts.to_json()).encode())
                p.stdin.close()
            except BrokenPipeError:  # a command that does not read its options
                pass
            return p.wait(timeout=timeout), False
        except subprocess.TimeoutExpired:
            _stop_group(p)
            return p.returncode, True
        except BaseException:
            _stop_group(p)
            raise


def _rejections(report):
    """{quantity: the firmware's reason} of the estimates report.json says were not accepted."""
    out = {}
    for q, row in ((report or {}).get("parameters") or {}).items():
        if row.get("estimate") is not None and not row.get("accepted") and row.get("reason"):
            out[q] = row["reason"]
    return out


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: another user's process
        return True
    return True


def sweep_stale(root=None):
    """Removes the mission directories of worker processes that no longer run on this host
    (in `root`, default the temp dir); a live process's are kept (a reused pid keeps them
    too: the safe side). Returns how many were removed."""
    root = Path(root or tempfile.gettempdir())
    n = 0
    try:
        found = list(root.glob(TMP_PREFIX + "*"))
    except OSError:
        return 0
    for d in found:
        m = TMP_RE.match(d.name)
        if not m or int(m.group(1)) == os.getpid() or _alive(int(m.group(1))) or not d.is_dir():
            continue
        shutil.rmtree(d, ignore_errors=True)
        n += 1 if not d.exists() else 0
    return n


_swept = False


def run_mission(job):
    """One mission; returns a dict (never raises for the mission's own failures)."""
    import socket

    global _swept
    if not _swept:  # once per worker process: what a killed predecessor left here
        _swept = True
        sweep_stale()
    t0 = time.monotonic()
    cpu0 = _cpu_s()
    res = {
        "index": job["index"],
        "seed": job["seed"],
        "status": "error",
        "reason": "",
        "report": None,
        "output_tail": [],
        "rejections": {},
        "host": socket.gethostname(),
        "wall_s": 0.0,
    }
    with tempfile.TemporaryDirectory(prefix=f"{TMP_PREFIX}{os.getpid()}-{job['index']:04d}-") as tmp:
        tmp = Path(tmp)
        try:
            (tmp / "vehicle.json").write_text(json.dumps(job["vehicle"], indent=1))
            opts = mission_options(job, tmp)
            log = tmp / "mission.log"
            if job.get("in_worker"):
                rc, timed_out = _mission_in_worker(opts, log, job["timeout"])
            else:
                rc, timed_out = _mission_subprocess(
                    mission_command(job.get("mission_cmd")), opts, log, tmp, job["timeout"]
                )
            tail = _tail(log)
            res["output_tail"] = tail
            # the reason: octo-gcs's own error line if it printed one, else the last line of output
            said = [ln[len("octo-gcs: ") :].strip().rstrip(":") for ln in tail if ln.startswith("octo-gcs: ")]
            last = said[0] if said else next((ln.strip() for ln in reversed(tail) if ln.strip()), "")
            aborted = [m.group(0) for m in map(ABORTED_RE.search, tail) if m]
            failed_run = tmp / "out" / "failed-run"
            if failed_run.is_dir():  # the failed run's program logs (tails): the worker's copy goes away
                res["failed_logs"] = {
                    p.name: "\n".join(_tail(p, 200)) + "\n" for p in sorted(failed_run.glob("*.log"))
                }
            rp = tmp / "out" / "report.json"
            if timed_out:
                res["status"] = "timeout"
                res["reason"] = f"no end after {job['timeout']:g} s" + (
                    f" (last output: {last})" if last else ""
                )
            elif rp.exists() and rc in (0, 1):
                try:
                    res["report"] = json.loads(rp.read_text())
                    res["rejections"] = _rejections(res["report"])
                    res["status"] = "pass" if rc == 0 else "fail"
                    if rc == 1:
                        failed = [
                            c["check"]
                            for c in res["report"].get("checks", [])
                            if not c.get("ok") and not c.get("warning_only")
                        ]
                        res["reason"] = "failed checks: " + "; ".join(failed) if failed else "exit status 1"
                except (ValueError, OSError) as e:
                    res["status"], res["reason"] = "crash", f"unreadable report.json: {e}"
            elif rc == 1 and said and " exited with status 1: " in said[0] and aborted:
                res["status"], res["reason"] = "aborted", aborted[0]
            else:
                res["status"] = "crash"
                why = f"killed by signal {-rc}" if rc < 0 else f"exit status {rc}"
                res["reason"] = why + (f": {last}" if last else "")
        except Exception as e:
            res["status"], res["reason"] = "error", f"{type(e).__name__}: {e}"
    res["wall_s"] = round(time.monotonic() - t0, 3)
    res["cpu_s"] = round(_cpu_s() - cpu0, 3)
    return res


def _cpu_s():
    """CPU seconds of this process (all its threads) and of its children that ended."""
    import resource

    return sum(
        r.ru_utime + r.ru_stime
        for r in (resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN))
    )


def warm_up():
    """Imports what an in-process mission needs (run once on each worker before the missions,
    so that the missions' rate is not that of the first imports)."""
    from . import analysis, logs  # noqa: F401
    from .mission import report, run  # noqa: F401

    return os.getpid()


# ---------------------------------------------------------------- results.csv
def csv_columns(spec):
    draw_cols = list(campaign_spec.draws(spec, 0))  # build, sensors, then every value of the spec
    cols = ["index", "seed", "status", "reason", "wall_s", "host"] + draw_cols
    for q in QUANTITIES + (RATIO,):
        cols += [f"{q}_truth", f"{q}_estimate", f"{q}_sd", f"{q}_error_pct", f"{q}_accepted"]
    return cols + ["source", "not_identifiable", "rejection_reasons", "failed_checks"]


def result_row(res, draws):
    row = {
        "index": res["index"],
        "seed": res["seed"],
        "status": res["status"],
        "reason": res["reason"],
        "wall_s": res["wall_s"],
        "host": res.get("host", ""),
    }
    row.update({k: repr(v) if isinstance(v, float) else v for k, v in draws.items()})
    rep = res.get("report") or {}
    params = rep.get("parameters", {})
    for q in QUANTITIES + (RATIO,):
        r = (params.get(q) if q != RATIO else rep.get("ktau_over_izz")) or {}
        for field in ("truth", "estimate", "sd", "error_pct"):
            v = r.get(field)
            row[f"{q}_{field}"] = "" if v is None else repr(float(v))
        row[f"{q}_accepted"] = "" if not r or r.get("estimate") is None else int(bool(r.get("accepted")))
    row["source"] = (rep.get("estimator") or {}).get("source") or ""
    row["not_identifiable"] = " ".join(
        q for q in QUANTITIES if (params.get(q) or {}).get("identifiable") is False
    )
    row["rejection_reasons"] = "; ".join(
        f"{q}: {why}" for q, why in sorted(res.get("rejections", {}).items())
    )
    row["failed_checks"] = "; ".join(
        c["check"] for c in rep.get("checks", []) if not c.get("ok") and not c.get("warning_only")
    )
    return row


def read_results(path, columns):
    """Complete rows of results.csv (a last line cut short by a crash is dropped and the file
    rewritten without it). Raises CampaignError if its columns are not `columns`."""
    if not path.exists():
        return []
    with open(path, newline="", encoding="utf-8") as f:
        text = f.read()
    rows = list(csv.reader(text.splitlines(keepends=True)))
    if not rows:
        return []
    if rows[0] != columns:
        raise CampaignError(
            f"{path}: its columns are not this spec's (another campaign?): choose another --out", status=2
        )
    good = [r for r in rows[1:] if len(r) == len(columns)]
    complete = text.endswith("\n")
    if not complete and good and len(good) == len(rows) - 1:
        good = good[:-1]  # the last row has all its fields but no line end: it may be cut short
    if len(good) != len(rows) - 1 or not complete:
        _rewrite(path, columns, good)
    return [dict(zip(columns, r)) for r in good]


def _rewrite(path, columns, rows):
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    w.writerows(rows)
    atomic_write(path, buf.getvalue())


class ResultsFile:
    """results.csv opened for appending; every row is flushed and fsynced at once."""

    def __init__(self, path, columns):
        new = not path.exists() or path.stat().st_size == 0
        self.f = open(path, "a", newline="", encoding="utf-8")
        self.w = csv.DictWriter(self.f, fieldnames=columns, lineterminator="\n")
        if new:
            self.w.writeheader()
            self._sync()

    def _sync(self):
        self.f.flush()
        os.fsync(self.f.fileno())

    def append(self, row):
        self.w.writerow(row)
        self._sync()

    def close(self):
        self.f.close()


# ---------------------------------------------------------------- the client
def mission_has_in_process(cmd):
    """True when the mission command given for tests takes the in-process plant (its --help says
    --in-process)."""
    try:
        p = subprocess.run(cmd + ["--help"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return "--in-process" in p.stdout


def replay_command(out, res_index, seed, spec, faults, params, build="float", sensors=None):
    """The one `octo-gcs mission` line that flies mission `res_index` again (its vehicle file is
    in DIR/missions/NNNN/)."""
    d = Path(out) / "missions" / f"{res_index:04d}"
    cmd = ["octo-gcs", "mission", "--vehicle", str(d / "vehicle.json"), "--seed", str(seed)]
    if spec.get("plant") == "in-process":
        cmd.append("--in-process")  # octo-sil: the same bytes as the campaign's mission
    if build == "fixed":
        cmd.append("--fixed")
    if sensors:
        cmd += ["--sensors", ",".join(sensors)]
    if spec["experiments"] != [6]:
        cmd += ["--experiments", ",".join(map(str, spec["experiments"])) or "none"]
    for name, value in sorted(params.items()):
        cmd += ["--param", f"{name}={value!r}"]
    for name, value in sorted(faults.items()):
        cmd += ["--fault", f"{name}={value!r}"]
    return " ".join(shlex.quote(c) for c in cmd)


def _fmt_minutes(s):
    if s is None:
        return "?"
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def _allowed_failures(dask_scheduler=None):
    return dask_scheduler.allowed_failures


def _start_cluster(args, spec, prog):
    import logging

    import dask
    from dask.distributed import Client, LocalCluster

    # worker-saturation 1.0: a worker holds only the mission it runs, so a worker that dies takes
    # no queued mission with it (Dask counts a death against every task the worker held)
    dask.config.set(
        {
            "distributed.scheduler.allowed-failures": spec["retries"],
            "distributed.scheduler.worker-saturation": 1.0,
        }
    )
    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout=30)
        except (OSError, TimeoutError) as e:
            raise CampaignError(f"cannot reach the Dask scheduler {args.scheduler}: {e}") from None
        n = len(client.scheduler_info().get("workers", {}))
        try:  # the scheduler's own retry count (its configuration, not this client's)
            retries = int(client.run_on_scheduler(_allowed_failures))
        except Exception:
            retries = None
        prog.say(f"campaign: Dask cluster {args.scheduler}, {n} workers")
        return client, None, n, retries
    n = args.workers or os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        memory_limit=0,
        silence_logs=logging.ERROR,
    )
    client = Client(cluster)
    prog.say(f"campaign: local Dask cluster of {n} worker processes")
    return client, cluster, n, spec["retries"]


def run(args):
    """The command; returns the exit status."""
    from . import campaign_report

    prog = Progress(stream=sys.stderr)
    try:
        spec = campaign_spec.load(args.spec)
        campaign_spec.check_all_draws(spec)
    except SpecError as e:
        print(f"octo-gcs campaign: {e}", file=sys.stderr)
        return 2
    if args.workers is not None and args.workers < 1:
        print("octo-gcs campaign: --workers must be >= 1", file=sys.stderr)
        return 2
    out = Path(args.out)
    try:
        return _run(args, spec, out, prog, campaign_report)
    except CampaignError as e:
        prog.done()
        print(f"octo-gcs campaign: {e}", file=sys.stderr)
        return e.status


def _run(args, spec, out, prog, campaign_report):
    columns = csv_columns(spec)
    results = out / "results.csv"
    done_rows = _open_out(args, spec, out, results, columns)
    done = {int(r["index"]) for r in done_rows}
    total = campaign_spec.flights(spec)
    todo = [i for i in range(total) if i not in done]
    override = os.environ.get(MISSION_ENV) or None
    in_process = _in_process(spec, todo, override, prog)
    plant = "in-process (octo-sil)" if in_process else "udp (octo-sim + octo-fw)"
    sets = campaign_spec.sensor_sets(spec)
    each = f" ({spec['missions']} vehicles x {len(sets)} sensor sets)" if sets else ""
    prog.say(
        f"campaign {spec['name']}: {total} missions{each}, seeds {spec['seed']}..{spec['seed'] + spec['missions'] - 1}, "
        f"{len(done)} already in {results}, plant {plant}"
    )
    jobs, inputs = _jobs(spec, todo, in_process, override)
    t0 = time.monotonic()
    stats = {
        "n_new": 0,
        "failures": sum(1 for r in done_rows if r["status"] not in RAN),
        "workers": 0,
        "t_run": None,
        "cpu": [],
        "done": len(done),
        "total": total,
    }
    if jobs:
        stopped = _fly_all(
            args, spec, jobs, inputs, out, results, columns, prog, stats, warm=in_process and not override
        )
        if stopped is not None:
            return stopped
    wall = time.monotonic() - t0
    run_s = time.monotonic() - stats["t_run"] if stats["t_run"] is not None else 0.0
    n_new, cpu = stats["n_new"], stats["cpu"]
    throughput = {
        "missions_this_run": n_new,
        "wall_s": round(wall, 2),
        "missions_s": round(run_s, 2),
        "workers": stats["workers"],
        "plant": plant,
        "missions_per_min": round(n_new / run_s * 60.0, 3) if n_new and run_s > 0 else None,
        "mission_cpu_s_mean": round(sum(cpu) / len(cpu), 4) if cpu else None,
    }
    rows = read_results(results, columns)
    summary = campaign_report.write(
        out, spec, rows, columns, throughput, replay=lambda idx, seed: _replay(out, spec, idx, seed)
    )
    for line in summary["lines"]:
        print(line)
    return 0 if summary["ok"] else 1


def _open_out(args, spec, out, results, columns):
    """DIR made ready (its spec.json checked against the spec on --resume); returns the rows
    already in results.csv (none without --resume)."""
    spec_copy = out / "spec.json"
    spec_text = json.dumps(spec, indent=1, sort_keys=True) + "\n"
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / "missions").mkdir(exist_ok=True)
    except OSError as e:
        raise CampaignError(f"cannot write {out}: {e.strerror}", status=2) from None
    if results.exists() and not args.resume:
        raise CampaignError(
            f"{results} exists: add --resume to go on with that campaign, or choose another --out", status=2
        )
    if args.resume and spec_copy.exists() and spec_copy.read_text() != spec_text:
        raise CampaignError(
            f"--resume: {args.spec} is not the spec {out} was started with ({spec_copy})", status=2
        )
    atomic_write(spec_copy, spec_text)
    return read_results(results, columns) if args.resume else []


def _in_process(spec, todo, override, prog):
    """Whether the missions fly in-process (octo-sil): the spec's choice, when the mission
    command given for tests can."""
    if spec["plant"] != "in-process" or not todo:
        return False
    if override is None or mission_has_in_process(mission_command(override)):
        return True
    prog.say(
        "campaign: the spec asks for the in-process plant, but this octo-gcs mission has no "
        "--in-process: missions use the UDP plant (octo-sim + octo-fw)"
    )
    return False


def _jobs(spec, todo, in_process, override):
    """The tasks of the missions `todo`, and each mission's draws."""
    inputs, jobs = {}, []
    for i in todo:
        seed, d, vehicle, faults, params = campaign_spec.mission_inputs(spec, i)
        w = campaign_spec.words(spec, i)
        inputs[i] = d
        jobs.append({
            "index": i, "seed": seed, "vehicle": vehicle, "faults": faults, "params": params,
            "build": w["build"], "sensors": w["sensors"],
            "experiments": spec["experiments"], "timeout": float(spec["timeout"]),
            "in_process": in_process, "mission_cmd": override,
            # octo-gcs's own in-process mission runs inside the worker's Python process
            # (octo-sil its child); a mission command given for tests stays a subprocess
            "in_worker": in_process and override is None,
        })  # fmt: skip
    return jobs, inputs


def _not_run(j, fut, retries):
    """The row of a task that came back without a result: its worker died, it raised or the
    cluster cancelled it."""
    from distributed.scheduler import KilledWorker

    if fut.status == "cancelled":
        status, why = "lost", "cancelled by the cluster"
    else:
        exc = fut.exception()
        if isinstance(exc, KilledWorker):
            status = "lost"
            why = (
                f"lost: the worker running it died {retries + 1} times (Dask retried it {retries} times)"
                if retries is not None
                else f"lost: the workers running it died: {str(exc).splitlines()[0]}"
            )
        else:
            status, why = "error", f"{type(exc).__name__}: {exc}"
    return {"index": j["index"], "seed": j["seed"], "status": status, "reason": why, "wall_s": "", "host": ""}


def _fly_all(args, spec, jobs, inputs, out, results, columns, prog, stats, warm):
    """Submits the jobs to the cluster and records each result as it comes (results.csv,
    missions/NNNN/). Returns None, or the exit status of a campaign stopped by a signal."""
    import uuid

    from dask.distributed import as_completed

    from .procs import Terminated, signals_as_exceptions

    client, cluster, stats["workers"], retries = _start_cluster(args, spec, prog)
    if warm:
        try:
            client.run(warm_up)
        except Exception as e:  # a worker without this octo_gcs: the missions will say so
            prog.say(f"campaign: the workers could not import the mission ({type(e).__name__}: {e})")
    stats["t_run"] = time.monotonic()  # the missions' own rate, without the cluster's start
    rf = ResultsFile(results, columns)
    futures = []
    try:
        with signals_as_exceptions():
            tag = uuid.uuid4().hex[:8]
            futures = [
                client.submit(run_mission, j, key=f"mission-{j['index']:05d}-{tag}", pure=False) for j in jobs
            ]
            by_key = {f.key: j for f, j in zip(futures, jobs)}
            for fut in as_completed(futures):
                j = by_key[fut.key]
                res = fut.result() if fut.status == "finished" else _not_run(j, fut, retries)
                fut.release()
                _record(out, rf, res, j, inputs, prog, spec, stats, len(jobs))
    except (KeyboardInterrupt, Terminated) as e:
        prog.done()
        how = "interrupted" if isinstance(e, KeyboardInterrupt) else f"stopped by {e}"
        print(
            f"octo-gcs campaign: {how}; {stats['done'] + stats['n_new']} of {stats['total']} missions are in "
            f"{results} (--resume goes on)",
            file=sys.stderr,
        )
        return 130 if isinstance(e, KeyboardInterrupt) else 143
    finally:
        rf.close()
        for f in futures:
            f.cancel()
        client.close()
        if cluster is not None:
            cluster.close()
            sweep_stale()  # local workers: what those killed left in this host's temp dir
    prog.done()
    return None


def _record(out, rf, res, j, inputs, prog, spec, stats, n_jobs):
    """One mission's result: its files, its row, the progress line."""
    if isinstance(res.get("cpu_s"), float):
        stats["cpu"].append(res["cpu_s"])  # CPU seconds on its worker (its process and children)
    _keep_mission(out, res, j)
    rf.append(result_row(res, inputs[j["index"]]))
    stats["n_new"] += 1
    if res["status"] not in RAN:
        stats["failures"] += 1
    n_new = stats["n_new"]
    el = time.monotonic() - stats["t_run"]
    rate = n_new / el * 60.0 if el > 0 else 0.0
    left = (n_jobs - n_new) / (rate / 60.0) if rate > 0 else None
    prog.update(
        f"campaign {spec['name']}: {stats['done'] + n_new}/{stats['total']} done, {stats['failures']} failed, "
        f"{rate:.1f} missions/min, {_fmt_minutes(left)} left",
        key=n_new,
    )


def _replay(out, spec, idx, seed):
    _seed, _d, _vehicle, faults, params = campaign_spec.mission_inputs(spec, idx)
    w = campaign_spec.words(spec, idx)
    return replay_command(out, idx, seed, spec, faults, params, w["build"], w["sensors"])


def _keep_mission(out, res, job):
    """DIR/missions/NNNN/: vehicle.json, report.json (when the mission wrote one), mission.log (its
    last lines of output)."""
    d = out / "missions" / f"{job['index']:04d}"
    d.mkdir(parents=True, exist_ok=True)
    atomic_write(d / "vehicle.json", json.dumps(job["vehicle"], indent=1) + "\n")
    if res.get("report") is not None:
        atomic_write(d / "report.json", json.dumps(res["report"], indent=1) + "\n")
    elif (d / "report.json").exists():
        os.unlink(d / "report.json")
    tail = res.get("output_tail") or []
    atomic_write(d / "mission.log", "\n".join(tail) + ("\n" if tail else ""))
    if res.get("failed_logs"):
        (d / "failed-run").mkdir(exist_ok=True)
        for name, text in res["failed_logs"].items():
            atomic_write(d / "failed-run" / name, text)
