"""In-flight identification over MAVLink (the interface of firmware/app/experiment.h).

Start: COMMAND_LONG MAV_CMD_USER_1, param1 = experiment (1 rotor coefficients,
2 validation, 3 Ix, 4 Iy, 5 Iz, 6 the full sequence). The vehicle answers
IN_PROGRESS (or ACCEPTED) when it starts, then a final COMMAND_ACK ACCEPTED or
FAILED. A vehicle taking off or still settling answers IN_PROGRESS too, says
"Experiment N waits: <why>", and starts once it hovers (or fails, saying why). Each result arrives as data, an OCTO_ID_RESULT message (id_results.py); a
run's missing ones are asked for again with MAV_CMD_REQUEST_MESSAGE. STATUSTEXTs
"ID k/n: <phase>", "ID done" or "ID aborted: <why>" name the phases for the progress
line, and the texts are shown to the user; live estimates come as NAMED_VALUE_FLOAT.
The results are also in the ID_* parameters; accepted ones are applied to VEH_*.
"""

import time

from .base import MODE_NUMBERS, MODES, GcsError
from .experiments import EXPERIMENTS, phase_of
from .id_results import Collector

# live estimates (NAMED_VALUE_FLOAT) shown on the progress line, in this order
LIVE = [
    ("KF", "KF_SD", "{:.4f}"),
    ("KTAU", "KTAU_SD", "{:.5f}"),
    ("IXX", "IXX_SD", "{:.5f}"),
    ("IYY", "IYY_SD", "{:.5f}"),
    ("IZZ", "IZZ_SD", "{:.5f}"),
]

SEV_ERROR = 3  # MAV_SEVERITY_ERROR (the syslog levels): the vehicle's failure reports
OCTO_ID_RESULT_ID = 54000


class Live:
    """What the vehicle says while an experiment runs: phase, progress, results."""

    def __init__(self, results=None):
        self.phase = ""
        self.phase_k = self.phase_n = 0
        self.progress = None
        self.results = results if results is not None else Collector()  # OCTO_ID_RESULT records
        self.done = None  # "done" | "aborted: why" | "failed"
        self.failure = None  # the vehicle's error text about the experiment (a phase's time limit)
        self.texts = []
        self.waiting = False  # the vehicle said the experiment waits for the hover

    def on_text(self, text, severity=None):
        if not text.startswith("ID"):
            return
        self.texts.append(text)
        ph = phase_of(text)
        if ph:
            self.phase_k, self.phase_n, self.phase = ph
        elif text == "ID done":
            self.done = "done"
        elif text.startswith("ID aborted"):
            self.done = "aborted" + text[len("ID aborted") :]
        elif severity is not None and severity <= SEV_ERROR and self.failure is None:
            self.failure = text

    def on_result(self, msg):
        self.results.add(msg)


def _start(v, experiment, start_timeout):
    """Sends the experiment's command until the vehicle starts it; raises GcsError on a refusal.
    A vehicle that does not fly answers DENIED "not hovering" (retried: an older firmware also
    answers so while it settles), one whose attitude still oscillates (the firmware lowering
    its gain) TEMPORARILY_REJECTED (retried)."""
    from .link import mavlink, result_name

    cmd, name = mavlink.MAV_CMD_USER_1, EXPERIMENTS[experiment]
    deadline = time.monotonic() + start_timeout
    confirmation = 0
    while True:
        t_cmd = time.time()
        v.conn.mav.command_long_send(
            v.target_system, v.target_component, cmd, confirmation, experiment, 0, 0, 0, 0, 0, 0
        )
        ack = v.recv("COMMAND_ACK", 1.5, cond=lambda a: a.command == cmd)
        if ack is None:
            confirmation += 1
            if confirmation >= 3:
                raise GcsError(f"no answer to experiment {experiment} ({name}) after 3 tries")
            continue
        r = ack.result
        if r in (mavlink.MAV_RESULT_IN_PROGRESS, mavlink.MAV_RESULT_ACCEPTED):
            return
        v.recv(types=(), timeout=0.05)  # the reason follows the ACK
        why = v._last_text(since=t_cmd)
        if (
            r == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
            or (r == mavlink.MAV_RESULT_DENIED and "hover" in why)
        ) and time.monotonic() < deadline:
            v.recv(types=(), timeout=0.2)
            continue
        raise GcsError(
            f"experiment {experiment} ({name}) refused: {result_name(r)}" + (f": {why}" if why else "")
        )


class _Bound:
    """An experiment's time limit: `timeout` s of wall time, or with `sim_time` (a callable: the
    simulated time, or None while unknown) `timeout` s of simulated time, the simulated time
    standing still for STALL_S of wall time being an error of its own (lockstep: the plant runs
    at the rate the firmware's host allows)."""

    STALL_S = 30.0

    def __init__(self, timeout, sim_time=None):
        self.timeout, self.sim_time = timeout, sim_time
        self.t0 = time.monotonic()
        self.s0 = self.s_last = sim_time() if sim_time else None
        self.moved = self.t0

    def exceeded(self):
        """None, or why the limit is passed."""
        now = time.monotonic()
        if self.sim_time is None:
            return f"still running after {self.timeout:g} s" if now - self.t0 > self.timeout else None
        t = self.sim_time()
        if t is not None and t != self.s_last:
            self.s_last, self.moved = t, now
            self.s0 = t if self.s0 is None else self.s0
        if now - self.moved > self.STALL_S:
            at = f" at t={self.s_last:.2f} s" if self.s_last is not None else ""
            return f"stopped: the simulated time stood still for {self.STALL_S:g} s of wall time{at}"
        if self.s0 is not None and self.s_last - self.s0 > self.timeout:
            return f"still running after {self.timeout:g} s simulated"
        return None


def _wait_end(v, live, state, t_wall0, bound, show, experiment):
    """Until the experiment ends: its final ACK, or its closing texts and the vehicle back in
    HOLD, or the vehicle leaving the experiment mode. Raises GcsError past `bound` (_Bound)."""
    from .link import mavlink, result_name

    t_text_done = None
    entered = False  # the vehicle was seen in the experiment mode
    while True:
        if state["final"] is not None:
            # the final ACK comes last (after the results are applied)
            v.recv(types=(), timeout=0.05)
            if live.done is None or state["final"] != mavlink.MAV_RESULT_ACCEPTED:
                live.done = (
                    "done"
                    if state["final"] == mavlink.MAV_RESULT_ACCEPTED
                    else (
                        live.done
                        if live.done and live.done != "done"
                        else f"failed ({result_name(state['final'])})"
                    )
                )
            return
        in_exp = v.mode == MODE_NUMBERS["EXPERIMENT"]
        entered = entered or in_exp
        if live.done is not None:
            # "ID done"/"ID aborted": the results are applied when the vehicle is back
            # in hold (or with the final ACK); don't wait forever for either
            t_text_done = t_text_done or time.monotonic()
            if not in_exp or time.monotonic() - t_text_done > 3.0:
                return
        elif (
            not in_exp
            and v.mode is not None
            and time.monotonic() - t_wall0 > 2.0
            and (entered or not live.waiting)
        ):
            # the vehicle left the experiment without the closing messages
            v.recv(types=(), timeout=0.3)
            if live.done is None and state["final"] is None:
                live.done = (
                    "done" if v.mode == MODE_NUMBERS["HOLD"] else f"ended in mode {MODES.get(v.mode, v.mode)}"
                )
            continue
        why = bound.exceeded()
        if why:
            raise GcsError(f"experiment {experiment} ({EXPERIMENTS[experiment]}) {why}")
        v.recv(types=(), timeout=0.05 if live.done else 0.1)
        show()


def request_missing_results(v, live, wait=1.0):
    """Asks the vehicle again for the results of its runs that did not all arrive (a lost
    datagram), with MAV_CMD_REQUEST_MESSAGE (param2 -1: every result of the last run)."""
    from .link import mavlink

    runs = live.results.runs()
    if runs and live.results.missing(runs[-1]) == []:
        return
    try:
        r = v.command(mavlink.MAV_CMD_REQUEST_MESSAGE, OCTO_ID_RESULT_ID, -1, timeout=1.0, retries=1)
    except GcsError:
        return  # no answer: the results stay as they came
    if r != mavlink.MAV_RESULT_ACCEPTED:
        return  # a vehicle that does not publish results as data
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        runs = live.results.runs()
        if runs and live.results.missing(runs[-1]) == []:
            return
        v.recv(types=(), timeout=0.05)


def run_experiment(
    v, experiment, progress, sim_time=None, timeout=120.0, start_timeout=10.0, results=None, sim_timeout=None
):
    """Runs one experiment on a hovering vehicle (link.Vehicle `v`); returns Live.

    progress: a progress.Progress (one line per phase when not a terminal).
    sim_time(): the vehicle's simulated time if the caller knows it (e.g. from the log
    it asked for); otherwise the wall time since the start is shown.
    timeout: the limit in s of wall time; sim_timeout (with sim_time): in s of simulated time
    instead (lockstep), with a simulation standing still for 30 s of wall time an error.
    results: an id_results.Collector that gathers the OCTO_ID_RESULT records (a new one by default).
    Raises GcsError if the vehicle refuses, aborts, fails or goes silent."""
    from .link import mavlink

    live = Live(results)
    cmd = mavlink.MAV_CMD_USER_1
    name = EXPERIMENTS[experiment]
    state = {"started": False, "final": None}
    t_wall0 = [time.monotonic()]

    def show():
        if sim_time is not None:
            ts = sim_time()
            tlabel = f"t={ts:7.2f} s" if ts is not None else ""
        else:
            tlabel = f"wall {time.monotonic() - t_wall0[0]:5.1f} s"
        ph = f"{live.phase_k}/{live.phase_n} {live.phase}" if live.phase else name
        pct = f" {live.progress:3d}%" if live.progress is not None else ""
        progress.update(
            f"ID {ph}{pct}  {tlabel}  {live_estimates(v)}".rstrip(), key=(live.phase_k, live.phase)
        )

    def listen(msg):
        t = msg.get_type()
        if t == "OCTO_ID_RESULT":
            live.on_result(msg)
        elif t == "STATUSTEXT":
            if msg.text.startswith(f"Experiment {experiment} ") and state["started"]:
                # not hovering yet: "Experiment N waits: <why>", then it starts, or
                # "Experiment N not started: <why>" with the final FAILED
                live.waiting = live.waiting or " waits: " in msg.text
                if " not started" in msg.text and live.failure is None:
                    live.failure = msg.text
                progress.say("  " + msg.text)
                return
            if not msg.text.startswith("ID"):
                return
            live.on_text(msg.text, msg.severity)
            if phase_of(msg.text):
                # a new phase streams its own estimates: forget the previous phase's
                for n, sd, _fmt in LIVE:
                    v.named_values.pop(n, None)
                    v.named_values.pop(sd, None)
                show()
            else:
                progress.say("  " + msg.text)
        elif t == "COMMAND_ACK" and msg.command == cmd and state["started"]:
            if msg.result == mavlink.MAV_RESULT_IN_PROGRESS:
                live.progress = msg.progress
            else:
                state["final"] = msg.result

    v.listeners.append(listen)
    try:
        _start(v, experiment, start_timeout)
        state["started"] = True
        t_wall0[0] = time.monotonic()
        show()
        bound = _Bound(sim_timeout, sim_time) if sim_timeout and sim_time else _Bound(timeout)
        _wait_end(v, live, state, t_wall0[0], bound, show, experiment)
        v.recv(types=(), timeout=0.05)  # trailing results and texts
        if live.done == "done":
            request_missing_results(v, live)
        est = live_estimates(v)
        progress.say(
            f"  {live.done} after {time.monotonic() - t_wall0[0]:.1f} s wall"
            + (f"; last live estimates: {est}" if est else "")
        )
    finally:
        v.listeners.remove(listen)
        progress.done()
    if live.failure:
        raise GcsError(f"experiment {experiment} ({name}) failed: {live.failure}; {live.done}")
    if live.done != "done":
        raise GcsError(f"experiment {experiment} ({name}) {live.done}")
    return live


def live_estimates(v):
    parts = []
    for name, sd, fmt in LIVE:
        if name in v.named_values and v.named_values[name][1] != 0.0:  # 0: not estimated yet
            s = fmt.format(v.named_values[name][1])
            if sd in v.named_values:
                s += " +/- " + fmt.format(v.named_values[sd][1])
            parts.append(f"{name} {s}")
    return "  ".join(parts)
