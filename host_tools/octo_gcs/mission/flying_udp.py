"""The flight with octo-sim and octo-fw over UDP (plant "udp").

Starts octo-sim (lockstep unless realtime) and octo-fw on free ports, both logging to LCM files
in the stage; waits for the vehicle; sets VEH_MASS and VEH_ARM_L from the vehicle file (what a
user measures on the bench) and the mission's parameters; arms, takes off, runs the
identification, collects every parameter over MAVLink, lands and stops both programs (also on
errors and Ctrl-C).

Every phase has a limit and a reason: the vehicle's own limits (a STATUSTEXT of severity ERROR
or worse that says "failed", e.g. "Take-off failed: NAV_TKO_TO ...") stop the mission at once
with that text; so does a helper program that exits, with the phase it was in and the vehicle's
last words; and the ground station's own waits name the phase and the limit.
"""

import os
import re
import time

from .. import id_results, procs
from ..base import GcsError
from ..experiments import EXPERIMENTS, planned_sim_seconds, planned_total
from ..identify import SEV_ERROR, run_experiment
from .flown import Flown
from .options import TAKEOFF_M, firmware_program, plant_flags, plant_words

# octo-fw's and octo-sim's words when a UDP port they were given is bound by another program
PORT_TAKEN_RE = re.compile(r"cannot bind .*Address already in use")
PORT_ATTEMPTS = 4


class PortTaken(GcsError):
    """octo-sim or octo-fw exited at start: a UDP port it was given was bound meanwhile."""


class FlightFailed(GcsError):
    """The flight stopped: the message says why; phase, the vehicle's error texts and all its
    status texts go into the failure report."""

    def __init__(self, msg, phase, vehicle_errors, texts):
        super().__init__(msg)
        self.phase, self.vehicle_errors, self.texts = phase, vehicle_errors, texts


def sim_argv(build, opts, ports, stage, sim_limit):
    """octo-sim's command line."""
    xp_port, xp_listen, _mav_port, _gcs_port = ports
    argv = [
        build / "octo-sim",
        "--xp-port",
        xp_port,
        "--data-out",
        f"127.0.0.1:{xp_listen}",
        "--seed",
        opts.seed,
        "--xplane-version",
        opts.xplane_version,
        "--lcm",
        f"file://{stage / 'truth.lcm'}",
        "--duration",
        sim_limit,
    ]
    if not opts.realtime:
        argv.append("--lockstep")
    if opts.vehicle:
        argv += ["--vehicle", os.path.abspath(opts.vehicle)]
    return argv + plant_flags(opts)


def fw_argv(build, ports, stage, program="octo-fw"):
    """octo-fw's (or octo-fw-fixed's) command line."""
    xp_port, xp_listen, mav_port, gcs_port = ports
    return [
        build / program,
        "--xplane",
        f"127.0.0.1:{xp_port}",
        "--xp-listen",
        xp_listen,
        "--mavlink-listen",
        mav_port,
        "--gcs",
        f"127.0.0.1:{gcs_port}",
        "--params",
        stage / "fw-storage.parm",
        "--lcm",
        f"file://{stage / 'fw.lcm'}",
    ]


class UdpFlight:
    def __init__(self, opts, prog):
        self.opts = opts
        self.prog = prog
        self.sim = self.fw = None
        self.vehicle = None
        self.results = id_results.Collector()
        self.phase = "start"  # what the mission is doing (named in a failure)
        self.phase_since = time.time()
        self.sim_limit = max(
            300.0, 3 * planned_total(opts.params, opts.experiments) + 200.0
        )  # bounds the logs

    def set_phase(self, name):
        self.phase, self.phase_since = name, time.time()

    def vehicle_failures(self, since=0.0):
        """The vehicle's failure reports (severity ERROR or worse, saying "failed")."""
        if self.vehicle is None:
            return []
        return [
            t
            for (w, sev, t) in self.vehicle.statustexts
            if w >= since and sev <= SEV_ERROR and "failed" in t.lower()
        ]

    def vehicle_errors(self, since=0.0):
        """Every text of severity ERROR or worse (the failure and what it adds)."""
        if self.vehicle is None:
            return []
        return [t for (w, sev, t) in self.vehicle.statustexts if w >= since and sev <= SEV_ERROR]

    # ------------------------------------------------------------ processes
    def _alive(self):
        failures = self.vehicle_failures(self.phase_since) if self.vehicle is not None else []
        if failures:
            self.vehicle.recv(types=(), timeout=0.1)  # the lines that explain it follow
            why = "; ".join(self.vehicle_errors(self.phase_since))
            if failures[0].startswith("Hold entry failed"):
                self.phase = "hold entry"  # the take-off's last part: at the height, settling
            raise GcsError(f"{self.phase} failed: {why}")
        for p in (self.sim, self.fw):
            if p is not None and not p.alive():
                rc = p.popen.returncode
                what = f"{p.name} exited with status {rc}"
                if p is self.sim and rc == 0:
                    what += f" (its --duration of {self.sim_limit:g} s simulated ran out)"
                last = self.vehicle._last_text() if self.vehicle is not None else ""
                raise GcsError(
                    f"{self.phase} failed: {what}"
                    + (f"; last message from the vehicle: {last}" if last else "")
                    + f":\n{p.tail()}"
                )

    def start(self, build, ports, stage):
        self.sim = procs.Proc(
            sim_argv(build, self.opts, ports, stage, self.sim_limit), stage / "octo-sim.log", "octo-sim"
        )
        fw = firmware_program(self.opts)
        self.fw = procs.Proc(fw_argv(build, ports, stage, fw), stage / "octo-fw.log", fw)

    def stop(self):
        procs.stop_all([self.fw, self.sim])

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

    def start_up(self, build, stage):
        """Starts octo-sim and octo-fw on free UDP ports and waits for the vehicle. A port is
        chosen free, then bound by the child a moment later: another program can take it in
        between (two missions starting together). Such a start is retried on fresh ports,
        up to PORT_ATTEMPTS times, and said; any other failure is not retried."""
        from ..link import Vehicle

        for attempt in range(1, PORT_ATTEMPTS + 1):
            # a fresh ground-station socket per start: the stopped octo-fw of a failed start
            # may have sent heartbeats to the last one, and the link would answer its address
            if self.vehicle is not None:
                self.vehicle.close()
            self.vehicle = Vehicle("udpin:127.0.0.1:0", timeout=self.opts.timeout)
            self.vehicle.listeners.append(self._on_message)
            gcs_port = self.vehicle.conn.port.getsockname()[1]
            ports = (procs.free_udp_port(), procs.free_udp_port(), procs.free_udp_port(), gcs_port)
            self.start(build, ports, stage)
            try:
                self.wait_up()
                return
            except PortTaken as e:
                self.stop()
                if attempt == PORT_ATTEMPTS:
                    raise GcsError(
                        f"{e}\n(a UDP port was taken at start {PORT_ATTEMPTS} times "
                        "in a row: is something binding many ports on 127.0.0.1?)"
                    ) from None
                first = str(e).splitlines()[-1].strip()
                self.prog.say(
                    f"start-up: a UDP port was taken before a program bound it ({first}); "
                    f"retrying on fresh ports ({attempt + 1} of {PORT_ATTEMPTS})"
                )

    def _on_message(self, msg):
        if msg.get_type() == "OCTO_ID_RESULT":
            self.results.add(msg)

    # ------------------------------------------------------------ the flight
    def set_bench(self, veh):
        """Sets the bench values and the mission's parameters; returns the parameters before
        identification (with those)."""
        v, t0 = self.vehicle, time.monotonic()
        nominal = v.fetch_params()
        bench = {"VEH_MASS": veh["mass"], "VEH_ARM_L": veh["arm_length"]}
        if "ID_SEED" in nominal:
            bench["ID_SEED"] = float(self.opts.seed)
        for name, value in self.opts.params.items():
            if name not in nominal:
                raise GcsError(f"--param {name}: the vehicle has no such parameter")
            bench[name] = value
        for name, value in bench.items():
            v.set_param(name, value)
        self.prog.say(
            "vehicle up; set "
            + ", ".join(f"{k} {val:g}" for k, val in bench.items())
            + f"  ({time.monotonic() - t0:.1f} s)"
        )
        nominal.update({k: float(val) for k, val in bench.items()})
        return nominal

    def fly(self, veh, stage):
        """Everything over MAVLink after start_up; returns (params before, params after)."""
        from ..flight import Flight
        from ..logs import LogTail

        say, t0 = self.prog.say, time.monotonic()
        fl = Flight(self.vehicle, alive=self._alive)
        nominal = self.set_bench(veh)
        tail = LogTail(str(stage / "fw.lcm"))
        # in lockstep take-off and landing are bounded in the vehicle's (simulated) time: the
        # plant runs as fast as the firmware's host allows, below real time on an emulated one
        tlimit, clock = (120.0, None) if self.opts.realtime else (30.0, tail.time)
        self.set_phase("arming")
        fl.arm()
        self.set_phase("take-off")
        fl.takeoff(TAKEOFF_M, timeout=tlimit, clock=clock)
        say(
            f"take-off: holding at {TAKEOFF_M:g} m (t={tail.time() or 0:.1f} s simulated, "
            f"{time.monotonic() - t0:.1f} s wall)"
        )
        for e in self.opts.experiments:
            self.set_phase(f"experiment {e}")
            say(f"experiment {e}: {EXPERIMENTS[e]}")
            n0 = len(self.results)
            planned = planned_sim_seconds(nominal, e)
            run_experiment(
                self.vehicle,
                e,
                self.prog,
                sim_time=tail.time,
                results=self.results,
                timeout=planned * 1.5 + 60.0,
                sim_timeout=None if self.opts.realtime else planned * 1.5 + 60.0,
            )
            say(
                f"experiment {e} done at t={tail.time() or 0:.1f} s simulated "
                f"({len(self.results) - n0} results, {time.monotonic() - t0:.1f} s wall)"
            )
        self.set_phase("collecting parameters")
        after = self.vehicle.fetch_params()
        say(f"collected {len(after)} parameters")
        self.set_phase("landing")
        fl.land(timeout=tlimit, clock=clock)
        say(
            f"landed and disarmed at t={tail.time() or 0:.1f} s simulated ({time.monotonic() - t0:.1f} s wall)"
        )
        tail.close()
        return nominal, after

    def try_land(self):
        """After an error: bring the vehicle down if it still flies (best effort)."""
        from ..flight import Flight
        from ..link import MODE_NUMBERS

        v = self.vehicle
        if v is None or self.sim is None or not self.sim.alive() or not self.fw.alive():
            return
        if v.mode in (None, MODE_NUMBERS["DISARMED"]):
            return
        try:
            Flight(v).land(timeout=15.0 if self.opts.realtime else 5.0)
        except Exception:
            pass

    def failed(self, e):
        texts = [t for (_, _, t) in self.vehicle.statustexts] if self.vehicle is not None else []
        return FlightFailed(str(e), self.phase, self.vehicle_errors(), texts)


def describe(opts, staged):
    mode = "real time" if opts.realtime else "lockstep"
    vname = f"vehicle {opts.vehicle}" if opts.vehicle else "the paper's vehicle"
    return (
        f"mission: octo-sim ({mode}, X-Plane {opts.xplane_version}, seed {opts.seed}, {vname}"
        f"{plant_words(opts)}) + {firmware_program(opts)} from {staged.build}"
    )


def fly(opts, staged, prog):
    """The flight; returns Flown. Raises FlightFailed (a GcsError) with the phase it stopped in."""
    if not os.access(staged.build / firmware_program(opts), os.X_OK):
        raise GcsError(
            f"{staged.build / firmware_program(opts)} not found: run `make` first, or give --build-dir"
        )
    flight = UdpFlight(opts, prog)
    try:
        flight.start_up(staged.build, staged.stage)
        nominal, after = flight.fly(staged.vehicle, staged.stage)
    except GcsError as e:
        flight.try_land()
        raise flight.failed(e) from None
    finally:
        flight.stop()
        if flight.vehicle is not None:
            flight.vehicle.close()
    records = flight.results.records()
    after, filled = id_results.merge(after, records)
    if filled:
        prog.say(f"note: the vehicle has no parameters {', '.join(filled)}: taken from its results")
    plant = "octo-sim " + ("real time" if opts.realtime else "lockstep")
    return Flown(nominal, after, records, filled, plant)
