"""``octo-gcs mission``: the whole identification flight in one command.

Starts octo-sim (lockstep unless --realtime) and octo-fw on free ports, both
logging to LCM files; waits for the vehicle; sets VEH_MASS and VEH_ARM_L from the
vehicle file (what a user measures on the bench); arms, takes off, runs the
identification (experiment 6: validation, k_f/k_tau, validation, Ix, Iy, Iz),
collects every parameter over MAVLink, lands, stops both programs (also on
errors and Ctrl-C) and writes the report, the parameters, the logs and the
figures into DIR.

Nothing half-written is left in DIR: the run works in DIR/.tmp-<pid>/ and moves
finished files into DIR at the end (report.md and report.json last). A failed
run leaves its logs in DIR/failed-run/ instead, with a report.md / report.json
that name the phase that failed and why.

Every phase has a limit and a reason: the vehicle's own limits (a STATUSTEXT of
severity ERROR or worse that says "failed", e.g. "Take-off failed: NAV_TKO_TO ...")
stop the mission at once with that text; so does a helper program that exits, with
the phase it was in and the vehicle's last words; and the ground station's own
waits name the phase and the limit.
"""

import json
import os
import re
import shutil
import sys
import time
from pathlib import Path

from . import paramfile, procs, vehiclefile
from .identify import EXPERIMENTS, merge_text_results, parse_experiments, planned_sim_seconds, run_experiment
from .base import GcsError
from .progress import Progress

TAKEOFF_M = 10.0
SEV_ERROR = 3   # STATUSTEXT severity ERROR (MAV_SEVERITY_ERROR: the syslog levels)
# octo-fw's and octo-sim's words when a UDP port they were given is bound by another program
PORT_TAKEN_RE = re.compile(r"cannot bind .*Address already in use")
PORT_ATTEMPTS = 4
OUTPUTS = ("report.md", "report.json", "params.parm", "truth.lcm", "fw.lcm", "octo-sim.log", "octo-fw.log", "octo-sil.log",
           "fig5_excitation.png", "fig6_validation.png", "fig7_rates.png", "convergence.png")


def _experiments_option(text):
    if str(text).strip().lower() in ("none", "0", ""):
        return []
    return parse_experiments(text)


def _param_options(items):
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise GcsError(f"--param {item!r}: expected NAME=VALUE, e.g. ID_INR_TIME=20") from None
    return out


class PortTaken(GcsError):
    """octo-sim or octo-fw exited at start: a UDP port it was given was bound meanwhile."""


class Mission:
    def __init__(self, args, out=None):
        self.args = args
        self.prog = out or Progress()
        self.sim = self.fw = None
        self.vehicle = None
        self.stage = None
        self.from_texts = []
        self.params_only = {}
        self.phase = "start"          # what the mission is doing (named in a failure)
        self.phase_since = time.time()
        self.failure = None           # the reason the mission stopped, once it did

    def set_phase(self, name):
        self.phase, self.phase_since = name, time.time()

    def vehicle_failures(self, since=0.0):
        """The vehicle's failure reports (severity ERROR or worse, saying "failed")."""
        if self.vehicle is None:
            return []
        return [t for (w, sev, t) in self.vehicle.statustexts
                if w >= since and sev <= SEV_ERROR and "failed" in t.lower()]

    def vehicle_errors(self, since=0.0):
        """Every text of severity ERROR or worse (the failure and what it adds)."""
        if self.vehicle is None:
            return []
        return [t for (w, sev, t) in self.vehicle.statustexts if w >= since and sev <= SEV_ERROR]

    # ------------------------------------------------------------ processes
    def _alive(self):
        failures = self.vehicle_failures(self.phase_since) if self.vehicle is not None else []
        if failures:
            self.vehicle.recv(types=(), timeout=0.1)   # the lines that explain it follow
            why = "; ".join(self.vehicle_errors(self.phase_since))
            if failures[0].startswith("Hold entry failed"):
                self.phase = "hold entry"   # the take-off's last part: at the height, settling
            raise GcsError(f"{self.phase} failed: {why}")
        for p in (self.sim, self.fw):
            if p is not None and not p.alive():
                rc = p.popen.returncode
                what = f"{p.name} exited with status {rc}"
                if p is self.sim and rc == 0:
                    what += f" (its --duration of {self.args.sim_limit:g} s simulated ran out)"
                last = self.vehicle._last_text() if self.vehicle is not None else ""
                raise GcsError(f"{self.phase} failed: {what}"
                               + (f"; last message from the vehicle: {last}" if last else "")
                               + f":\n{p.tail()}")

    def start(self, build, vehicle_file, ports, stage):
        a = self.args
        xp_port, xp_listen, mav_port, gcs_port = ports
        sim_args = [build / "octo-sim", "--xp-port", xp_port, "--data-out", f"127.0.0.1:{xp_listen}",
                    "--seed", a.seed, "--xplane-version", a.xplane_version,
                    "--lcm", f"file://{stage / 'truth.lcm'}", "--duration", a.sim_limit]
        if not a.realtime:
            sim_args.append("--lockstep")
        if vehicle_file:
            sim_args += ["--vehicle", os.path.abspath(vehicle_file)]
        self.sim = procs.Proc(sim_args, stage / "octo-sim.log", "octo-sim")
        fw_args = [build / "octo-fw", "--xplane", f"127.0.0.1:{xp_port}", "--xp-listen", xp_listen,
                   "--mavlink-listen", mav_port, "--gcs", f"127.0.0.1:{gcs_port}",
                   "--params", stage / "fw-storage.parm", "--lcm", f"file://{stage / 'fw.lcm'}"]
        self.fw = procs.Proc(fw_args, stage / "octo-fw.log", "octo-fw")

    def stop(self):
        procs.stop_all([self.fw, self.sim])

    # ------------------------------------------------------------ the flight
    def wait_up(self):
        """Until octo-fw's first heartbeat. A program that dies at start is reported at once,
        with its output; one that could not bind its UDP port raises PortTaken."""
        deadline = time.monotonic() + 10.0
        while True:
            try:
                self._alive()
            except GcsError as e:
                if PORT_TAKEN_RE.search(str(e)):
                    raise PortTaken(str(e)) from None
                raise
            try:
                self.vehicle.wait_heartbeat(timeout=0.2)
                return
            except GcsError:
                if time.monotonic() > deadline:
                    raise GcsError("no heartbeat from octo-fw after 10 s:\n" + self.fw.tail()) from None

    def start_up(self, build, vehicle_file, stage):
        """Starts octo-sim and octo-fw on free UDP ports and waits for the vehicle. A port is
        chosen free, then bound by the child a moment later: another program can take it in
        between (two missions starting together). Such a start is retried on fresh ports,
        up to PORT_ATTEMPTS times, and said; any other failure is not retried."""
        from .link import Vehicle
        for attempt in range(1, PORT_ATTEMPTS + 1):
            # a fresh ground-station socket per start: the stopped octo-fw of a failed start
            # may have sent heartbeats to the last one, and the link would answer its address
            if self.vehicle is not None:
                self.vehicle.close()
            self.vehicle = Vehicle("udpin:127.0.0.1:0", timeout=self.args.timeout)
            gcs_port = self.vehicle.conn.port.getsockname()[1]
            ports = (procs.free_udp_port(), procs.free_udp_port(), procs.free_udp_port(), gcs_port)
            self.start(build, vehicle_file, ports, stage)
            try:
                self.wait_up()
                return
            except PortTaken as e:
                self.stop()
                if attempt == PORT_ATTEMPTS:
                    raise GcsError(f"{e}\n(a UDP port was taken at start {PORT_ATTEMPTS} times "
                                   "in a row: is something binding many ports on 127.0.0.1?)") from None
                first = str(e).splitlines()[-1].strip()
                self.prog.say(f"start-up: a UDP port was taken before a program bound it ({first}); "
                              f"retrying on fresh ports ({attempt + 1} of {PORT_ATTEMPTS})")

    def fly(self, veh, experiments, stage):
        """Everything over MAVLink after start_up; returns (params before, params after)."""
        a, say = self.args, self.prog.say
        v = self.vehicle
        t0 = time.monotonic()
        from .flight import Flight
        fl = Flight(v, alive=self._alive)
        nominal = v.fetch_params()
        bench = {"VEH_MASS": veh["mass"], "VEH_ARM_L": veh["arm_length"]}
        if "ID_SEED" in nominal:
            bench["ID_SEED"] = float(a.seed)
        for name, value in a.param_values.items():
            if name not in nominal:
                raise GcsError(f"--param {name}: the vehicle has no such parameter")
            bench[name] = value
        for name, value in bench.items():
            v.set_param(name, value)
        say(f"vehicle up; set " + ", ".join(f"{k} {val:g}" for k, val in bench.items())
            + f"  ({time.monotonic() - t0:.1f} s)")
        nominal.update({k: float(val) for k, val in bench.items()})
        tail = _tail(stage / "fw.lcm")
        tlimit = 30.0 if not a.realtime else 120.0
        self.set_phase("arming")
        fl.arm()
        self.set_phase("take-off")
        fl.takeoff(TAKEOFF_M, timeout=tlimit)
        say(f"take-off: holding at {TAKEOFF_M:g} m (t={tail.time() or 0:.1f} s simulated, "
            f"{time.monotonic() - t0:.1f} s wall)")
        texts = []
        for e in experiments:
            self.set_phase(f"experiment {e}")
            say(f"experiment {e}: {EXPERIMENTS[e]}")
            planned = planned_sim_seconds(nominal, e)
            live = run_experiment(v, e, self.prog, sim_time=tail.time,
                                  timeout=planned * (1.5 if a.realtime else 0.5) + 60.0)
            texts += live.texts
            say(f"experiment {e} done at t={tail.time() or 0:.1f} s simulated "
                f"({len(live.results)} results, {time.monotonic() - t0:.1f} s wall)")
        self.set_phase("collecting parameters")
        after = v.fetch_params()
        say(f"collected {len(after)} parameters")
        after, self.from_texts = merge_text_results(after, texts)
        if self.from_texts:
            say(f"note: the vehicle has no parameters {', '.join(self.from_texts)}: "
                "taken from its status texts")
        self.params_only = {k: after[k] for k in after if k not in self.from_texts}
        self.set_phase("landing")
        fl.land(timeout=tlimit)
        say(f"landed and disarmed at t={tail.time() or 0:.1f} s simulated "
            f"({time.monotonic() - t0:.1f} s wall)")
        tail.close()
        return nominal, after

    def try_land(self):
        """After an error: bring the vehicle down if it still flies (best effort)."""
        v = self.vehicle
        if v is None or self.sim is None or not self.sim.alive() or not self.fw.alive():
            return
        from .flight import Flight
        from .link import MODE_NUMBERS
        if v.mode in (None, MODE_NUMBERS["DISARMED"]):
            return
        try:
            Flight(v).land(timeout=15.0 if self.args.realtime else 5.0)
        except Exception:
            pass


def _tail(path):
    from .logs import LogTail
    return LogTail(str(path))


def prepare(args):
    """What both mission paths check and set up first: the experiments and parameter options,
    the vehicle file, the build directory and a fresh staging directory in DIR (published by
    rename at the end, so DIR never holds half a mission). Raises GcsError naming the input."""
    experiments = _experiments_option(args.experiments)
    args.param_values = _param_options(args.param)
    try:
        veh = vehiclefile.load(args.vehicle)
    except vehiclefile.VehicleFileError as e:
        raise GcsError(str(e)) from None
    build = procs.build_dir(args.build_dir)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        stage = Path(out / f".tmp-{os.getpid()}")
        if stage.exists():
            shutil.rmtree(stage)
        stage.mkdir()
    except OSError as e:
        raise GcsError(f"cannot write {out}: {e.strerror}") from None
    return experiments, veh, build, out, stage


def run(args):
    if getattr(args, "in_process", False):
        from . import inprocess
        return inprocess.run(args)
    from .report import build_report, write_outputs

    t_start = time.monotonic()
    prog = Progress()
    experiments, veh, build, out, stage = prepare(args)
    planned = sum(planned_sim_seconds(args.param_values, e) for e in experiments) if experiments else 0.0
    args.sim_limit = max(300.0, 3 * planned + 200.0)   # bounds the logs if anything hangs
    m = Mission(args, out=prog)
    ok = False
    mode = "real time" if args.realtime else "lockstep"
    vname = f"vehicle {args.vehicle}" if args.vehicle else "the paper's vehicle"
    prog.say(f"mission: octo-sim ({mode}, X-Plane {args.xplane_version}, seed {args.seed}, {vname}) "
             f"+ octo-fw from {build}")
    try:
        with procs.signals_as_exceptions():
            try:
                m.start_up(build, args.vehicle, stage)
                nominal, after = m.fly(veh, experiments, stage)
            except GcsError as e:
                m.failure = str(e)
                m.try_land()
                raise
            finally:
                m.stop()
                if m.vehicle is not None:
                    m.vehicle.close()
            wall_flight = time.monotonic() - t_start
            prog.say(f"flight done in {wall_flight:.1f} s; building the report")
            paramfile.save(stage / "params.parm", m.params_only)
            if (stage / "fw-storage.parm").exists():
                os.unlink(stage / "fw-storage.parm")   # octo-fw's own storage: params.parm says it
            rep = build_report(stage, veh, args, nominal, after, experiments,
                               wall_flight_s=wall_flight, from_texts=m.from_texts)
            write_outputs(stage, rep, args.plots)
            rep["timing"]["wall_total_s"] = round(time.monotonic() - t_start, 2)
            files = _publish(stage, out, rep)
            ok = True
    except GcsError as e:
        _failure_report(stage, m, str(e), args)
        dest = _keep_failed(stage, out)
        raise GcsError(f"{e}" + (f"\n(the logs of the failed run are in {dest}/)" if dest else "")) from None
    finally:
        if not ok:
            dest = _keep_failed(stage, out)
            if dest:
                print(f"octo-gcs: the logs of the failed run are in {dest}/", file=sys.stderr)
    from .report import table_text
    print()
    print(table_text(rep))
    print()
    verdict = "PASS" if rep["pass"] else "FAIL"
    print(f"{verdict}: {len(files)} files in {out}/ ({', '.join(files)}); "
          f"{rep['timing']['wall_total_s']:.1f} s")
    for c in rep["checks"]:
        if not c["ok"]:
            print(f"  {'warning' if c['warning_only'] else 'failed'}: {c['check']}: {c['detail']}")
    return 0 if rep["pass"] else 1


def _publish(stage, out, rep):
    """Moves the finished files into DIR, reports last; removes the stage."""
    from .atomicfile import atomic_write
    from .report import dumps
    rep["files"] = sorted({p.name for p in stage.iterdir() if p.is_file()} | {"report.json"})
    atomic_write(stage / "report.json", dumps(rep))
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


def _failure_report(stage, m, reason, args):
    """report.md / report.json of a failed run: the phase, the reason, the vehicle's
    error texts and every status text, the files kept (written atomically)."""
    if stage is None or not stage.exists():
        return
    from .atomicfile import atomic_write
    texts = [t for (_, _, t) in m.vehicle.statustexts] if m.vehicle is not None else []
    files = sorted(p.name for p in stage.iterdir() if p.is_file())
    first = reason.splitlines()[0] if reason else "unknown"
    rep = {"pass": False, "failed_phase": m.phase, "failure": first, "failure_detail": reason,
           "vehicle_errors": m.vehicle_errors(), "statustexts": texts, "seed": args.seed,
           "vehicle_file": str(args.vehicle) if args.vehicle else None,
           "files": sorted(set(files) | {"report.md", "report.json"})}
    md = [f"# Mission FAILED in phase: {m.phase}", "", f"**Reason:** {first}", ""]
    if len(reason.splitlines()) > 1:
        md += ["```", *reason.splitlines()[1:], "```", ""]
    if rep["vehicle_errors"]:
        md += ["## Errors reported by the vehicle", "", *[f"- {t}" for t in rep["vehicle_errors"]], ""]
    md += ["## Status texts", "", *[f"- {t}" for t in texts], "", "## Files", "",
           *[f"- {f}" for f in rep["files"]], ""]
    try:
        atomic_write(stage / "report.json", json.dumps(rep, indent=2) + "\n")
        atomic_write(stage / "report.md", "\n".join(md))
    except OSError:
        pass


def _keep_failed(stage, out):
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
