"""In-flight identification over MAVLink (the interface of firmware/app/experiment.h).

Start: COMMAND_LONG MAV_CMD_USER_1, param1 = experiment (1 rotor coefficients,
2 validation, 3 Ix, 4 Iy, 5 Iz, 6 the full sequence). The vehicle answers
IN_PROGRESS (or ACCEPTED) when it starts, then a final COMMAND_ACK ACCEPTED or
FAILED; STATUSTEXTs "ID k/n: <phase>", one per result, and "ID done" or
"ID aborted: <why>"; live estimates as NAMED_VALUE_FLOAT. The results are read
back from the ID_* parameters; accepted ones are also in VEH_*.
"""

import math
import re
import time

from .base import MODE_NUMBERS, MODES, GcsError, fw_default

EXPERIMENTS = {1: "rotor coefficients", 2: "validation", 3: "Ix", 4: "Iy", 5: "Iz",
               6: "full sequence"}


class Quantity:
    def __init__(self, key, label, unit, est, sd, plain, veh, bit, exp):
        self.key, self.label, self.unit = key, label, unit
        self.est, self.sd, self.plain, self.veh = est, sd, plain, veh
        self.bit, self.exp = bit, exp


QUANTITIES = [
    Quantity("kf", "k_f", "N", "ID_KF_EST", "ID_KF_SD", "ID_KF_PLAIN", "VEH_KF", 1, 1),
    Quantity("ktau", "k_tau", "N m", "ID_KTAU_EST", "ID_KTAU_SD", "ID_KTAU_PLAIN", "VEH_KTAU", 1, 1),
    Quantity("ixx", "I_x", "kg m^2", "ID_IXX_EST", "ID_IXX_SD", None, "VEH_IXX", 2, 3),
    Quantity("iyy", "I_y", "kg m^2", "ID_IYY_EST", "ID_IYY_SD", None, "VEH_IYY", 4, 4),
    Quantity("izz", "I_z", "kg m^2", "ID_IZZ_EST", "ID_IZZ_SD", None, "VEH_IZZ", 8, 5),
]
BY_KEY = {q.key: q for q in QUANTITIES}

# live estimates (NAMED_VALUE_FLOAT) shown on the progress line, in this order
LIVE = [("KF", "KF_SD", "{:.4f}"), ("KTAU", "KTAU_SD", "{:.5f}"), ("IXX", "IXX_SD", "{:.5f}"),
        ("IYY", "IYY_SD", "{:.5f}"), ("IZZ", "IZZ_SD", "{:.5f}")]

PHASE_RE = re.compile(r"^ID (\d+)/(\d+): (.*)$")
RESULT_RE = re.compile(r"^ID (\S+) .*\b(accepted|rejected)\b")
FAILED_RE = re.compile(r"^ID (.+?) failed: ")


def quantities_of(experiments):
    """The quantities experiments identify (6 = all; 2 = none)."""
    exps = set(experiments)
    if 6 in exps:
        return list(QUANTITIES)
    return [q for q in QUANTITIES if q.exp in exps]


def parse_experiments(text):
    """'6' or '1,3,4' -> [6] / [1, 3, 4] (checked)."""
    out = []
    for part in str(text).replace(" ", ",").split(","):
        if not part:
            continue
        try:
            n = int(part)
        except ValueError:
            raise GcsError(f"experiment {part!r} is not a number (1..6)") from None
        if n not in EXPERIMENTS:
            raise GcsError(f"experiment {n} unknown: " +
                           ", ".join(f"{k} {v}" for k, v in EXPERIMENTS.items()))
        out.append(n)
    if not out:
        raise GcsError("no experiment given")
    return out


def planned_sim_seconds(params, experiment):
    """Simulated seconds an experiment should last, from the ID_* parameters (an estimate
    for the time-outs; the firmware may add settling time)."""
    exc = params.get("ID_EXC_TIME", fw_default("ID_EXC_TIME"))
    val = params.get("ID_VAL_TIME", fw_default("ID_VAL_TIME"))
    inr = params.get("ID_INR_TIME", fw_default("ID_INR_TIME"))
    return {1: exc, 2: val, 3: inr, 4: inr, 5: inr, 6: 2 * val + exc + 3 * inr}[experiment]


class Live:
    """What the vehicle says while an experiment runs: phase, progress, estimates."""

    def __init__(self):
        self.phase = ""
        self.phase_k = self.phase_n = 0
        self.progress = None
        self.results = []       # result STATUSTEXTs
        self.done = None        # "done" | "aborted: why" | "failed"
        self.failure = None     # the vehicle's "ID <phase> failed: <why>" (a phase's time limit)
        self.texts = []

    def on_text(self, text):
        if not text.startswith("ID"):
            return
        self.texts.append(text)
        m = PHASE_RE.match(text)
        if m:
            self.phase_k, self.phase_n, self.phase = int(m.group(1)), int(m.group(2)), m.group(3)
        elif text == "ID done":
            self.done = "done"
        elif text.startswith("ID aborted"):
            self.done = "aborted" + text[len("ID aborted"):]
        elif FAILED_RE.match(text):
            self.failure = text
        elif RESULT_RE.match(text):
            self.results.append(text)


def run_experiment(v, experiment, progress, sim_time=None, timeout=120.0, start_timeout=10.0):
    """Runs one experiment on a hovering vehicle (link.Vehicle `v`); returns Live.

    progress: a progress.Progress (one line per phase when not a terminal).
    sim_time(): the vehicle's simulated time if the caller knows it (e.g. from the log
    it asked for); otherwise the wall time since the start is shown.
    Raises GcsError if the vehicle refuses, aborts, fails or goes silent."""
    from .link import mavlink, result_name

    live = Live()
    cmd = mavlink.MAV_CMD_USER_1
    name = EXPERIMENTS[experiment]
    state = {"started": False, "final": None, "ack": None}
    t_wall0 = [time.monotonic()]

    def show():
        if sim_time is not None:
            ts = sim_time()
            tlabel = f"t={ts:7.2f} s" if ts is not None else ""
        else:
            tlabel = f"wall {time.monotonic() - t_wall0[0]:5.1f} s"
        ph = f"{live.phase_k}/{live.phase_n} {live.phase}" if live.phase else name
        pct = f" {live.progress:3d}%" if live.progress is not None else ""
        progress.update(f"ID {ph}{pct}  {tlabel}  {live_estimates(v)}".rstrip(),
                        key=(live.phase_k, live.phase))

    def listen(msg):
        t = msg.get_type()
        if t == "STATUSTEXT":
            if not msg.text.startswith("ID"):
                return
            live.on_text(msg.text)
            if PHASE_RE.match(msg.text):
                # a new phase streams its own estimates: forget the previous phase's
                for n, sd, _fmt in LIVE:
                    v.named_values.pop(n, None)
                    v.named_values.pop(sd, None)
                show()
            else:
                progress.say("  " + msg.text)
        elif t == "COMMAND_ACK" and msg.command == cmd:
            if not state["started"]:
                state["ack"] = msg
            elif msg.result == mavlink.MAV_RESULT_IN_PROGRESS:
                live.progress = msg.progress
            else:
                state["final"] = msg.result

    v.listeners.append(listen)
    try:
        # start it; a vehicle still settling after take-off answers DENIED "not hovering", one
        # whose attitude still oscillates (the firmware lowering its gain) TEMPORARILY_REJECTED
        deadline = time.monotonic() + start_timeout
        confirmation = 0
        while True:
            t_cmd = time.time()
            state["ack"] = None
            v.conn.mav.command_long_send(v.target_system, v.target_component, cmd, confirmation,
                                         experiment, 0, 0, 0, 0, 0, 0)
            ack = v.recv("COMMAND_ACK", 1.5, cond=lambda a: a.command == cmd)
            if ack is None:
                confirmation += 1
                if confirmation >= 3:
                    raise GcsError(f"no answer to experiment {experiment} ({name}) after 3 tries")
                continue
            r = ack.result
            if r in (mavlink.MAV_RESULT_IN_PROGRESS, mavlink.MAV_RESULT_ACCEPTED):
                break
            v.recv(types=(), timeout=0.05)   # the reason follows the ACK
            why = v._last_text(since=t_cmd)
            if (r == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
                    or (r == mavlink.MAV_RESULT_DENIED and "hover" in why)) and time.monotonic() < deadline:
                v.recv(types=(), timeout=0.2)
                continue
            raise GcsError(f"experiment {experiment} ({name}) refused: {result_name(r)}"
                           + (f": {why}" if why else ""))
        state["started"] = True
        t_wall0[0] = time.monotonic()
        show()
        t_text_done = None
        while True:
            if state["final"] is not None:
                # the final ACK comes last (after the results are applied)
                v.recv(types=(), timeout=0.05)
                if live.done is None or state["final"] != mavlink.MAV_RESULT_ACCEPTED:
                    live.done = "done" if state["final"] == mavlink.MAV_RESULT_ACCEPTED else \
                        (live.done if live.done and live.done != "done"
                         else f"failed ({result_name(state['final'])})")
                break
            in_exp = v.mode == MODE_NUMBERS["EXPERIMENT"]
            if live.done is not None:
                # "ID done"/"ID aborted": the results are applied when the vehicle is back
                # in hold (or with the final ACK); don't wait forever for either
                t_text_done = t_text_done or time.monotonic()
                if not in_exp or time.monotonic() - t_text_done > 3.0:
                    break
            elif not in_exp and v.mode is not None and time.monotonic() - t_wall0[0] > 2.0:
                # the vehicle left the experiment without the closing messages
                v.recv(types=(), timeout=0.3)
                if live.done is None and state["final"] is None:
                    live.done = "done" if v.mode == MODE_NUMBERS["HOLD"] else \
                        f"ended in mode {MODES.get(v.mode, v.mode)}"
                continue
            if time.monotonic() - t_wall0[0] > timeout:
                raise GcsError(f"experiment {experiment} ({name}) still running after {timeout:g} s")
            v.recv(types=(), timeout=0.05 if live.done else 0.1)
            show()
        v.recv(types=(), timeout=0.05)   # trailing result texts
        est = live_estimates(v)
        progress.say(f"  {live.done} after {time.monotonic() - t_wall0[0]:.1f} s wall"
                     + (f"; last live estimates: {est}" if est else ""))
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
        if name in v.named_values and v.named_values[name][1] != 0.0:   # 0: not estimated yet
            s = fmt.format(v.named_values[name][1])
            if sd in v.named_values:
                s += " +/- " + fmt.format(v.named_values[sd][1])
            parts.append(f"{name} {s}")
    return "  ".join(parts)


_NUM = r"([-+0-9.eE]+|nan|inf)"
_TEXT_RESULTS = [
    (re.compile(rf"^ID kf {_NUM} \+/- {_NUM} N (accepted|rejected)"), ("ID_KF_EST", "ID_KF_SD"), 1),
    (re.compile(rf"^ID ktau {_NUM} \+/- {_NUM} N m (accepted|rejected)"), ("ID_KTAU_EST", "ID_KTAU_SD"), 1),
    (re.compile(rf"^ID Ixx {_NUM} \+/- {_NUM} kg m\^2 (accepted|rejected)"), ("ID_IXX_EST", "ID_IXX_SD"), 2),
    (re.compile(rf"^ID Iyy {_NUM} \+/- {_NUM} kg m\^2 (accepted|rejected)"), ("ID_IYY_EST", "ID_IYY_SD"), 4),
    (re.compile(rf"^ID Izz {_NUM} \+/- {_NUM} kg m\^2 (accepted|rejected)"), ("ID_IZZ_EST", "ID_IZZ_SD"), 8),
]
_TEXT_PLAIN = re.compile(rf"^ID plain \(eq\. 20\) kf {_NUM} N ktau {_NUM} N m")
_TEXT_VAL = re.compile(rf"^ID validation (before|after): NE {_NUM} fit {_NUM} %")


def results_from_texts(texts):
    """ID_* values as the vehicle's result STATUSTEXTs state them (rounded as printed):
    the fallback for a vehicle whose parameter table lacks them."""
    out, bits, seen_bits = {}, 0, 0
    for text in texts:
        for rx, (est, sd), bit in _TEXT_RESULTS:
            m = rx.match(text)
            if m:
                out[est], out[sd] = float(m.group(1)), float(m.group(2))
                seen_bits |= bit
                if m.group(3) == "accepted":
                    bits |= bit
                elif bit == 1:
                    bits &= ~1
        m = _TEXT_PLAIN.match(text)
        if m:
            out["ID_KF_PLAIN"], out["ID_KTAU_PLAIN"] = float(m.group(1)), float(m.group(2))
        m = _TEXT_VAL.match(text)
        if m:
            tag = "PRE" if m.group(1) == "before" else "POST"
            out[f"ID_VAL_NE_{tag}"], out[f"ID_VAL_FIT_{tag}"] = float(m.group(2)), float(m.group(3))
    if seen_bits:
        out["ID_RESULT"] = float(bits)
    return out


def merge_text_results(params, texts):
    """params plus the ID_* values only the status texts carry; returns (merged, names filled in)."""
    extra = {k: v for k, v in results_from_texts(texts).items() if k not in params}
    merged = dict(params)
    merged.update(extra)
    return merged, sorted(extra)


# ---------------------------------------------------------------- checks
class Check:
    def __init__(self, name, ok, detail, warning=False):
        self.name, self.ok, self.detail, self.warning = name, bool(ok), detail, warning

    def as_dict(self):
        return {"check": self.name, "ok": self.ok, "warning_only": self.warning, "detail": self.detail}

    def line(self):
        tag = "ok  " if self.ok else ("warn" if self.warning else "FAIL")
        return f"  [{tag}] {self.name}: {self.detail}"


def _finite_pos(x):
    return x is not None and math.isfinite(x) and x > 0


def plausibility(params, experiments, rounded=()):
    """Checks that need no truth: estimates present, finite, positive, accepted, their
    relative std within ID_RSD_MAX, applied to VEH_*, physically sensible; validation
    improved. `rounded`: names whose values came from status texts (rounded as printed).
    Returns [Check]."""
    checks = []
    rsd_max = params.get("ID_RSD_MAX")
    result_bits = int(params.get("ID_RESULT", 0))
    mass = params.get("VEH_MASS", fw_default("VEH_MASS"))
    g = params.get("VEH_GRAV", fw_default("VEH_GRAV"))
    for q in quantities_of(experiments):
        est, sd = params.get(q.est), params.get(q.sd)
        if not _finite_pos(est):
            checks.append(Check(f"{q.label} estimated", False, f"{q.est} = {est}"))
            continue
        detail = f"{est:.6g} +/- {sd:.3g} {q.unit}" if sd is not None else f"{est:.6g} {q.unit}"
        checks.append(Check(f"{q.label} estimated", _finite_pos(sd), detail))
        if rsd_max is not None and _finite_pos(sd):
            checks.append(Check(f"{q.label} relative std", sd / est <= rsd_max,
                                f"{100 * sd / est:.3f} % (limit {100 * rsd_max:.3g} %)"))
        checks.append(Check(f"{q.label} accepted", result_bits & q.bit, f"ID_RESULT = {result_bits}"))
        if result_bits & q.bit and q.veh in params:
            tol = 2e-3 if q.est in rounded else 1e-6
            same = abs(params[q.veh] - est) <= tol * abs(est)
            checks.append(Check(f"{q.label} applied", same, f"{q.veh} = {params[q.veh]:.6g}"))
    kf, ktau = params.get("ID_KF_EST"), params.get("ID_KTAU_EST")
    if any(q.key == "kf" for q in quantities_of(experiments)) and _finite_pos(kf):
        th = mass * g / (8 * kf)
        checks.append(Check("hover throttle m g / (8 k_f)", 0.02 <= th <= 0.9, f"{th:.4f} (0.02 .. 0.9)"))
        if _finite_pos(ktau):
            k = ktau / kf
            checks.append(Check("yaw coefficient k = k_tau / k_f", 0.001 <= k <= 0.1,
                                f"{k:.5f} m (0.001 .. 0.1)"))
    ixx, iyy, izz = (params.get(n) for n in ("ID_IXX_EST", "ID_IYY_EST", "ID_IZZ_EST"))
    if 6 in experiments and all(_finite_pos(x) for x in (ixx, iyy, izz)):
        checks.append(Check("inertia triangle inequality I_z <= I_x + I_y", izz <= ixx + iyy,
                            f"{izz:.5f} vs {ixx + iyy:.5f}", warning=True))
    if 6 in experiments or 2 in experiments:
        pre, post = params.get("ID_VAL_NE_PRE"), params.get("ID_VAL_NE_POST")
        if 6 in experiments and pre is not None and post is not None:
            checks.append(Check("validation error after identification: NE halved or < 0.05",
                                post < 0.5 * pre or post < 0.05,
                                f"NE {pre:.4f} -> {post:.4f}; fit {params.get('ID_VAL_FIT_PRE', float('nan')):.1f} % "
                                f"-> {params.get('ID_VAL_FIT_POST', float('nan')):.1f} %"))
    return checks


def against_truth(params, experiments, truth, tol_rotor_pct, tol_inertia_pct):
    """Error of each estimate against the truth {kf, ktau, ixx, iyy, izz}. Returns [Check]."""
    checks = []
    for q in quantities_of(experiments):
        est, true = params.get(q.est), truth[q.key]
        tol = tol_rotor_pct if q.key in ("kf", "ktau") else tol_inertia_pct
        if not _finite_pos(est):
            checks.append(Check(f"{q.label} vs truth", False, "no estimate"))
            continue
        err = 100.0 * (est - true) / true
        why = f"{tol:g} %"
        sd = params.get(q.sd)
        if q.key in ("kf", "ktau") and _finite_pos(sd) and 400.0 * sd / true > tol:
            # k_f is the thrust at full throttle: with the thrust curve estimated it is an
            # extrapolation from hover throttles, and its reported std says how far it holds
            tol = 400.0 * sd / true
            why = f"{tol:.3g} %: 4 sd"
        checks.append(Check(f"{q.label} vs truth", abs(err) <= tol,
                            f"{est:.6g} vs {true:.6g}: {err:+.3f} % (limit {why})"))
    return checks


MOTOR_RATE_HZ = 90.0


def motor_model_rows(params, veh):
    """The motor model found (lag, delay, curve, per-rotor scales) with its standard deviations
    beside the truth of the vehicle file (None: unknown). Rows: (label, found, sd, truth, error
    text) as strings."""
    def f(x, fmt="{:.4g}"):
        return "-" if x is None or not isinstance(x, (int, float)) or not math.isfinite(x) else fmt.format(x)

    rows = []
    tau, tau_sd = params.get("ID_TAU_CHECK"), params.get("ID_TAU_SD")
    t_tau = veh.get("motor_tau") if veh else None
    err = f"{100.0 * (tau - t_tau) / t_tau:+.2f} %" if tau is not None and t_tau else "-"
    rows.append(("motor lag [s]", f(tau), f(tau_sd), f(t_tau), err))
    d = params.get("ID_DELAY_FR")
    t_d = round(veh["delay"] * MOTOR_RATE_HZ) if veh and veh.get("delay") is not None else None
    rows.append(("transport delay [frames]", f(d, "{:.0f}"), "-", f(t_d, "{:.0f}"),
                 "-" if d is None or t_d is None else ("exact" if round(d) == t_d else f"{round(d) - t_d:+d}")))
    c, c_sd = params.get("MOT_CURVE"), params.get("ID_CRV_SD")
    t_c = veh.get("thrust_curve") if veh else None
    rows.append(("thrust curve c", f(c), f(c_sd), f(t_c), "-" if c is None or t_c is None else f"{c - t_c:+.4f}"))
    t_s = veh.get("rotor_scale") if veh else None
    for j in range(8):
        sj = params.get(f"MOT_SCALE{j + 1}")
        tj = t_s[j] if t_s else None
        rows.append((f"rotor {j + 1} effectiveness", f(sj), "-", f(tj),
                     "-" if sj is None or not tj else f"{100.0 * (sj - tj) / tj:+.2f} %"))
    rows.append(("residual / noise variance (NE)", f(params.get("ID_MOT_NE")), "-", "1", "-"))
    return rows


# ---------------------------------------------------------------- command
def run(args):
    from . import vehiclefile
    from .link import Vehicle
    from .progress import Progress

    experiments = parse_experiments(args.experiments)
    truth = None
    if args.expect:
        try:
            truth = vehiclefile.truth_of(vehiclefile.load(args.expect))
        except vehiclefile.VehicleFileError as e:
            raise GcsError(str(e)) from None
    prog = Progress()
    with Vehicle(args.connect, timeout=args.timeout, signing_key=args.signing_key) as v:
        v.wait_heartbeat()
        params = v.fetch_params()
        texts = []
        for e in experiments:
            if v.mode != MODE_NUMBERS["HOLD"]:
                raise GcsError(f"vehicle is in mode {MODES.get(v.mode, v.mode)}, not HOLD: "
                               "experiments need a hovering vehicle (take off first)")
            prog.say(f"experiment {e}: {EXPERIMENTS[e]}")
            wall = planned_sim_seconds(params, e) * args.time_factor + 30.0
            texts += run_experiment(v, e, prog, timeout=wall).texts
        params, filled = merge_text_results(v.fetch_params(), texts)
        if filled:
            print(f"note: the vehicle has no parameters {', '.join(filled)}: taken from its status texts")
    return report_checks(params, experiments, truth, args.tol_rotor, args.tol_inertia, rounded=filled)


def report_checks(params, experiments, truth, tol_rotor, tol_inertia, out=print, rounded=()):
    out("results:")
    for q in quantities_of(experiments):
        est, sd, plain = params.get(q.est), params.get(q.sd), params.get(q.plain) if q.plain else None
        line = f"  {q.label:<6} {est:.6g} +/- {sd:.3g} {q.unit}" if est is not None else f"  {q.label:<6} -"
        if plain is not None:
            line += f"   (plain LS {plain:.6g})"
        out(line)
    checks = plausibility(params, experiments, rounded)
    if truth is not None:
        checks += against_truth(params, experiments, truth, tol_rotor, tol_inertia)
    out("checks:")
    for c in checks:
        out(c.line())
    ok = all(c.ok or c.warning for c in checks)
    out("PASS" if ok else "FAIL")
    return 0 if ok else 1
