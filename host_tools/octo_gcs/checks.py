"""Checks of identification results: plausibility without a truth, errors against a truth,
and the motor model beside the truth (rows for the report)."""

import math

from .base import fw_default
from .quantities import quantities_of


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


def plausibility(params, experiments):
    """Checks that need no truth: estimates present, finite, positive, accepted, their
    relative std within ID_RSD_MAX, applied to VEH_*, physically sensible; validation
    improved.
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
            checks.append(
                Check(
                    f"{q.label} relative std",
                    sd / est <= rsd_max,
                    f"{100 * sd / est:.3f} % (limit {100 * rsd_max:.3g} %)",
                )
            )
        checks.append(Check(f"{q.label} accepted", result_bits & q.bit, f"ID_RESULT = {result_bits}"))
        if result_bits & q.bit and q.veh in params:
            same = abs(params[q.veh] - est) <= 1e-6 * abs(est)
            checks.append(Check(f"{q.label} applied", same, f"{q.veh} = {params[q.veh]:.6g}"))
    kf, ktau = params.get("ID_KF_EST"), params.get("ID_KTAU_EST")
    if any(q.key == "kf" for q in quantities_of(experiments)) and _finite_pos(kf):
        th = mass * g / (8 * kf)
        checks.append(Check("hover throttle m g / (8 k_f)", 0.02 <= th <= 0.9, f"{th:.4f} (0.02 .. 0.9)"))
        if _finite_pos(ktau):
            k = ktau / kf
            checks.append(
                Check("yaw coefficient k = k_tau / k_f", 0.001 <= k <= 0.1, f"{k:.5f} m (0.001 .. 0.1)")
            )
    ixx, iyy, izz = (params.get(n) for n in ("ID_IXX_EST", "ID_IYY_EST", "ID_IZZ_EST"))
    if 6 in experiments and all(_finite_pos(x) for x in (ixx, iyy, izz)):
        checks.append(
            Check(
                "inertia triangle inequality I_z <= I_x + I_y",
                izz <= ixx + iyy,
                f"{izz:.5f} vs {ixx + iyy:.5f}",
                warning=True,
            )
        )
    if 6 in experiments or 2 in experiments:
        pre, post = params.get("ID_VAL_NE_PRE"), params.get("ID_VAL_NE_POST")
        if 6 in experiments and pre is not None and post is not None:
            checks.append(
                Check(
                    "validation error after identification: NE halved or < 0.05",
                    post < 0.5 * pre or post < 0.05,
                    f"NE {pre:.4f} -> {post:.4f}; fit {params.get('ID_VAL_FIT_PRE', float('nan')):.1f} % "
                    f"-> {params.get('ID_VAL_FIT_POST', float('nan')):.1f} %",
                )
            )
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
        checks.append(
            Check(
                f"{q.label} vs truth", abs(err) <= tol, f"{est:.6g} vs {true:.6g}: {err:+.3f} % (limit {why})"
            )
        )
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
    rows.append(
        (
            "transport delay [frames]",
            f(d, "{:.0f}"),
            "-",
            f(t_d, "{:.0f}"),
            "-" if d is None or t_d is None else ("exact" if round(d) == t_d else f"{round(d) - t_d:+d}"),
        )
    )
    c, c_sd = params.get("MOT_CURVE"), params.get("ID_CRV_SD")
    t_c = veh.get("thrust_curve") if veh else None
    rows.append(
        ("thrust curve c", f(c), f(c_sd), f(t_c), "-" if c is None or t_c is None else f"{c - t_c:+.4f}")
    )
    t_s = veh.get("rotor_scale") if veh else None
    for j in range(8):
        sj = params.get(f"MOT_SCALE{j + 1}")
        tj = t_s[j] if t_s else None
        rows.append(
            (
                f"rotor {j + 1} effectiveness",
                f(sj),
                "-",
                f(tj),
                "-" if sj is None or not tj else f"{100.0 * (sj - tj) / tj:+.2f} %",
            )
        )
    rows.append(("residual / noise variance (NE)", f(params.get("ID_MOT_NE")), "-", "1", "-"))
    return rows


def report_checks(params, experiments, truth, tol_rotor, tol_inertia, out=print, verdicts=None, source=None):
    """Prints the results and the checks; returns the exit status (0 pass, 1 fail). verdicts:
    {quantity key: {"accepted", "reason"}} of the firmware's result records, source: the
    measurements they rest on (both shown when given)."""
    out("results:" + (f" (from {source})" if source else ""))
    for q in quantities_of(experiments):
        est, sd, plain = params.get(q.est), params.get(q.sd), params.get(q.plain) if q.plain else None
        line = f"  {q.label:<6} {est:.6g} +/- {sd:.3g} {q.unit}" if est is not None else f"  {q.label:<6} -"
        if plain is not None:
            line += f"   (plain LS {plain:.6g})"
        v = (verdicts or {}).get(q.key)
        if v is not None and not v["accepted"]:
            line += f"   rejected: {v['reason']}"
        out(line)
    checks = plausibility(params, experiments)
    if truth is not None:
        checks += against_truth(params, experiments, truth, tol_rotor, tol_inertia)
    out("checks:")
    for c in checks:
        out(c.line())
    ok = all(c.ok or c.warning for c in checks)
    out("PASS" if ok else "FAIL")
    return 0 if ok else 1
