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


# ID_SRC_USED's codes (OCTO_ID_SOURCE) of the sources without ESC torque: the gyro sees the
# yaw torque's effect only as k_tau / I_z
SRC_NO_TORQUE = {2: "imu", 3: "imu_rpm"}


def source_used(params):
    """The source the firmware's last identification used, by name (ID_SRC_USED), or None."""
    src = params.get("ID_SRC_USED")
    if src is None or not math.isfinite(src) or src <= 0:
        return None
    return {1: "thrust", 2: "imu", 3: "imu_rpm", 4: "imu_rpm_torque"}.get(int(round(src)))


def unidentifiable(params):
    """The quantities the source used cannot determine alone: without ESC torque, I_z (only
    k_tau / I_z), and k_tau unless a prior on I_z (ID_IZZ_PRI_SD > 0) turns the ratio into it."""
    src = params.get("ID_SRC_USED")
    if src is None or not math.isfinite(src) or int(round(src)) not in SRC_NO_TORQUE:
        return set()
    pri = params.get("ID_IZZ_PRI_SD")
    return {"izz"} if _finite_pos(pri) else {"izz", "ktau"}


def plausibility(params, experiments, skip=None, verdicts=None):
    """Checks that need no truth: estimates present, finite, positive, accepted, their
    relative std within ID_RSD_MAX, applied to VEH_*, physically sensible; validation
    improved. skip: the quantities the source cannot determine alone (default
    unidentifiable(params)): their checks are not_identifiable_checks'. verdicts: the
    firmware's result records' {key: {"accepted", ...}}: a quantity is accepted when its
    ID_RESULT bit and its record both say so (k_f and k_tau share a bit).
    Returns [Check]."""
    checks = []
    skip = unidentifiable(params) if skip is None else set(skip)
    rsd_max = params.get("ID_RSD_MAX")
    result_bits = int(params.get("ID_RESULT", 0))
    mass = params.get("VEH_MASS", fw_default("VEH_MASS"))
    g = params.get("VEH_GRAV", fw_default("VEH_GRAV"))
    for q in quantities_of(experiments):
        if q.key in skip:
            continue
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
        accepted = bool(result_bits & q.bit) and (verdicts or {}).get(q.key, {}).get("accepted", True)
        checks.append(Check(f"{q.label} accepted", accepted, f"ID_RESULT = {result_bits}"))
        if accepted and q.veh in params:
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


def against_truth(params, experiments, truth, tol_rotor_pct, tol_inertia_pct, skip=None):
    """Error of each estimate against the truth {kf, ktau, ixx, iyy, izz}; the quantities in
    skip (default unidentifiable(params)) have no estimate to compare. Returns [Check]."""
    checks = []
    skip = unidentifiable(params) if skip is None else set(skip)
    for q in quantities_of(experiments):
        if q.key in skip:
            continue
        est, true = params.get(q.est), truth[q.key]
        tol = tol_rotor_pct if q.key in ("kf", "ktau") else tol_inertia_pct
        if not _finite_pos(est):
            checks.append(Check(f"{q.label} vs truth", False, "no estimate"))
            continue
        err = 100.0 * (est - true) / true
        why = f"{tol:g} %"
        sd = params.get(q.sd)
        if _finite_pos(sd) and 400.0 * sd / true > tol:
            # judged against its own reported sd too: k_f is the thrust at full throttle, an
            # extrapolation from hover throttles when the curve is estimated, and an inertia's
            # sd of 0.55 % puts the 2 % tolerance at 3.6 sd, which an honest estimate passes
            # once in 3,000 (a fixed tolerance within about 3 sd is no test of the estimate)
            tol = 400.0 * sd / true
            why = f"{tol:.3g} %: 4 sd"
        checks.append(
            Check(
                f"{q.label} vs truth", abs(err) <= tol, f"{est:.6g} vs {true:.6g}: {err:+.3f} % (limit {why})"
            )
        )
    return checks


def not_identifiable_checks(params, nominal, keys, expected, source):
    """The quantities the firmware reported as not identifiable (keys) are those its source
    cannot determine (expected), and none of them was applied (VEH_* as before the flight,
    no ID_RESULT bit). Returns [Check]."""
    from .quantities import BY_KEY

    checks = []
    bits = int(params.get("ID_RESULT", 0))
    for key in sorted(set(keys) | set(expected)):
        q = BY_KEY[key]
        why = []
        if key not in keys:
            why.append("the firmware gave no such result")
        if key not in expected:
            why.append(
                f"source {source} with ID_IZZ_PRI_SD {params.get('ID_IZZ_PRI_SD', 0):g} should identify it"
            )
        before, now = (nominal or {}).get(q.veh), params.get(q.veh)
        if before is not None and now is not None and abs(now - before) > 1e-6 * abs(before):
            why.append(f"{q.veh} changed {before:.6g} -> {now:.6g}")
        if key == "izz" and bits & q.bit:
            why.append(f"ID_RESULT = {bits} marks it accepted")
        detail = f"source {source}: the gyro gives k_tau / I_z only; {q.veh} kept at {now:.6g}" if now else ""
        checks.append(
            Check(
                f"{q.label} not identifiable from the gyro alone",
                not why,
                "; ".join(why) if why else detail or f"source {source}",
            )
        )
    return checks


TOL_RATIO_PCT = 2.0  # k_tau / I_z against the truth: max(3 sd, this)


def ratio_checks(row, tol_pct=TOL_RATIO_PCT):
    """k_tau / I_z (the report's row: estimate, sd, accepted, reason, truth): estimated,
    accepted, and within max(3 sd, tol_pct) of the truth when it is known. Returns [Check]."""
    est, sd = row.get("estimate"), row.get("sd")
    if not _finite_pos(est):
        return [Check("k_tau/I_z estimated", False, f"ID_KTIZ = {est}")]
    checks = [Check("k_tau/I_z estimated", _finite_pos(sd), f"{est:.6g} +/- {sd or float('nan'):.3g} 1/s^2")]
    checks.append(
        Check(
            "k_tau/I_z accepted",
            row.get("accepted"),
            "accepted" if row.get("accepted") else f"rejected: {row.get('reason') or 'no reason given'}",
        )
    )
    true = row.get("truth")
    if _finite_pos(true):
        err = 100.0 * (est - true) / true
        lim, why = tol_pct, f"{tol_pct:g} %"
        if _finite_pos(sd) and 300.0 * sd / true > tol_pct:
            lim, why = 300.0 * sd / true, f"{300.0 * sd / true:.3g} %: 3 sd"
        checks.append(
            Check(
                "k_tau/I_z vs truth", abs(err) <= lim, f"{est:.6g} vs {true:.6g}: {err:+.3f} % (limit {why})"
            )
        )
    return checks


MOTOR_RATE_HZ = 90.0


# the sources whose data tell the rotors apart (each rotor's effectiveness, MOT_SCALE): only the
# thrust rows; a rotor's speed is not its propeller's thrust, and the accelerometer sees the sum
SOURCES_PER_ROTOR = ("thrust",)


def motor_model_rows(params, veh, source=None):
    """The motor model found (lag, delay, curve, per-rotor scales) with its standard deviations
    beside the truth of the vehicle file (None: unknown). Rows: (label, found, sd, truth, error
    text) as strings. Under a source that cannot tell the rotors apart (the accelerometer sees
    their sum) the scales are "not identified": MOT_SCALE is what the flight assumed."""

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
    per_rotor = source is None or source in SOURCES_PER_ROTOR
    for j in range(8):
        sj = params.get(f"MOT_SCALE{j + 1}")
        tj = t_s[j] if t_s else None
        if not per_rotor:
            rows.append(
                (f"rotor {j + 1} effectiveness", f"not identified (source {source})", "-", f(tj), "-")
            )
            continue
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


def ratio_row(params, verdict=None, truth=None):
    """k_tau / I_z as the firmware identified it (ID_KTIZ, ID_KTIZ_SD) with its verdict (the
    result record's, else ID_RSD_MAX on its relative sd) and the truth: {"estimate", "sd",
    "sd_pct", "accepted", "reason", "truth", "error_pct", "error_over_sd"}."""
    est, sd = params.get("ID_KTIZ"), params.get("ID_KTIZ_SD")
    est = est if _finite_pos(est) else None
    sd = sd if est is not None and _finite_pos(sd) else None
    if verdict is not None:
        accepted, reason = verdict["accepted"], None if verdict["accepted"] else verdict["reason"]
    else:
        rsd_max = params.get("ID_RSD_MAX")
        accepted = est is not None and sd is not None and (rsd_max is None or sd / est < rsd_max)
        reason = None if accepted else "uncertain"
    err = 100.0 * (est - truth) / truth if est is not None and _finite_pos(truth) else None
    return {
        "label": "k_tau/I_z",
        "unit": "1/s^2",
        "estimate": est,
        "sd": sd,
        "sd_pct": 100.0 * sd / est if sd is not None else None,
        "accepted": bool(accepted) and est is not None,
        "reason": reason,
        "truth": truth,
        "error_pct": err,
        "error_over_sd": (est - truth) / sd if err is not None and sd else None,
    }


def has_ratio(params, experiments):
    """The firmware identified k_tau / I_z in place of k_tau and I_z (the yaw experiment ran
    under a source without ESC torque)."""
    return "izz" in unidentifiable(params) and bool({5, 6} & set(experiments))


def report_checks(
    params, experiments, truth, tol_rotor, tol_inertia, out=print, verdicts=None, source=None, ratio=None
):
    """Prints the results and the checks; returns the exit status (0 pass, 1 fail). verdicts:
    {quantity key: {"accepted", "reason"}} of the firmware's result records, source: the
    measurements they rest on (both shown when given); ratio: the k_tau / I_z result's verdict
    (id_results.ratio_verdict)."""
    skip = unidentifiable(params) | {
        k for k, v in (verdicts or {}).items() if v["reason"] == "not_identifiable"
    }
    out("results:" + (f" (from {source})" if source else ""))
    for q in quantities_of(experiments):
        if q.key in skip:
            out(f"  {q.label:<6} not identifiable from the gyro alone (the ratio k_tau/I_z below)")
            continue
        est, sd, plain = params.get(q.est), params.get(q.sd), params.get(q.plain) if q.plain else None
        line = f"  {q.label:<6} {est:.6g} +/- {sd:.3g} {q.unit}" if est is not None else f"  {q.label:<6} -"
        if plain is not None:
            line += f"   (plain LS {plain:.6g})"
        v = (verdicts or {}).get(q.key)
        if v is not None and not v["accepted"]:
            line += f"   rejected: {v['reason']}"
        out(line)
    checks = plausibility(params, experiments, skip, verdicts)
    if truth is not None:
        checks += against_truth(params, experiments, truth, tol_rotor, tol_inertia, skip)
    if has_ratio(params, experiments):
        t = truth["ktau"] / truth["izz"] if truth is not None else None
        row = ratio_row(params, ratio, t)
        est, sd = row["estimate"], row["sd"]
        out(
            f"  k_tau/I_z {est:.6g} +/- {sd or float('nan'):.3g} 1/s^2"
            if est is not None
            else "  k_tau/I_z -"
        )
        checks += ratio_checks(row)
    out("checks:")
    for c in checks:
        out(c.line())
    ok = all(c.ok or c.warning for c in checks)
    out("PASS" if ok else "FAIL")
    return 0 if ok else 1
