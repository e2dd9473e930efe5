"""The mission report: the paper's Table 1 beside the truth and both estimates.

`build_report` gathers everything into one dict (written as report.json);
`markdown` and `table_text` render it. The plain estimate is the paper's least
squares of the measured f_1, tau_1 on the commanded T_1 (eqs. 18-20), which a
lagging motor biases; the lag-aware estimate regresses on the command passed
through the motor model. Errors are relative to the truth, in percent.
"""

import datetime
import json
import math
import os

from . import __version__
from .atomicfile import atomic_write
from .identify import QUANTITIES, against_truth, motor_model_rows, plausibility, quantities_of
from .vehiclefile import PAPER, truth_of

PAPER_VALUES = {"kf": PAPER["kf"], "ktau": PAPER["ktau"], "ixx": PAPER["inertia"][0],
                "iyy": PAPER["inertia"][1], "izz": PAPER["inertia"][2]}

TOL_ROTOR_PCT = 0.3
TOL_INERTIA_PCT = 2.0


def _num(x, nd=None):
    """JSON-safe number (None for NaN/missing): rounded to `nd` decimals, or by default to
    9 significant digits, which keeps every float32 parameter exact (6 decimals would cost
    an inertia of 0.047 kg m^2 two thousandths of a percent)."""
    if x is None:
        return None
    x = float(x)
    if not math.isfinite(x):
        return None
    return round(x, nd) if nd is not None else float(f"{x:.9g}")


def _err(est, true):
    if est is None or true is None or not math.isfinite(est) or est == 0 or true == 0:
        return None
    return 100.0 * (est - true) / true


def truth_from_logs(logs, veh):
    """The truth: the vehicle file, or (with drift) the truth log's values at the end."""
    t = truth_of(veh)
    if logs is not None and logs.truth is not None and len(logs.truth):
        tr = logs.truth
        t = {"kf": float(tr.kf[-1]), "ktau": float(tr.ktau[-1]), "ixx": float(tr.inertia[-1, 0]),
             "iyy": float(tr.inertia[-1, 1]), "izz": float(tr.inertia[-1, 2])}
        # drifting k_f: the value in the middle of the log is the fairer truth
        if abs(tr.kf[-1] - tr.kf[0]) > 1e-9 * tr.kf[0]:
            i = len(tr) // 2
            t["kf"], t["ktau"] = float(tr.kf[i]), float(tr.ktau[i])
    return t


def parameter_rows(nominal, after, truth, experiments):
    rows = {}
    ident = {q.key for q in quantities_of(experiments)}
    for q in QUANTITIES:
        est = after.get(q.est) if q.key in ident else None
        est = est if est is not None and est > 0 else None
        sd = after.get(q.sd) if est is not None else None
        plain = after.get(q.plain) if (q.plain and est is not None) else None
        plain = plain if plain is not None and plain > 0 else None
        true = truth.get(q.key) if truth else None
        row = {
            "label": q.label, "unit": q.unit, "paper": PAPER_VALUES[q.key], "truth": _num(true),
            "nominal": _num(nominal.get(q.veh)), "plain": _num(plain),
            "plain_error_pct": _num(_err(plain, true), 4), "estimate": _num(est), "sd": _num(sd, 8),
            "sd_pct": _num(100.0 * sd / est if est and sd is not None else None, 4),
            "error_pct": _num(_err(est, true), 4),
            "error_over_sd": _num((est - true) / sd if est and sd and true else None, 3),
            "accepted": bool(int(after.get("ID_RESULT", 0)) & q.bit) if est is not None else False,
            "vehicle_value": _num(after.get(q.veh)),
        }
        rows[q.key] = row
    return rows


def _validation_params(after, tag):
    """The firmware's validation result (ID_VAL_*_PRE/POST); None when not run (0)."""
    suffix = "PRE" if tag == "before" else "POST"
    ne_, fit = after.get(f"ID_VAL_NE_{suffix}"), after.get(f"ID_VAL_FIT_{suffix}")
    if not ne_:
        return {"ne": None, "fit_pct": None}
    return {"ne": _num(ne_), "fit_pct": _num(fit, 3)}


def build_report(stage, veh, args, nominal, after, experiments, wall_flight_s=None, logs=None,
                 from_texts=()):
    """The report dict of a mission whose files are in `stage`."""
    from . import analysis
    from .logs import Logs

    if logs is None:
        paths = [p for p in (os.path.join(stage, "truth.lcm"), os.path.join(stage, "fw.lcm"))
                 if os.path.exists(p)]
        logs = Logs(paths) if paths else None
    truth = truth_from_logs(logs, veh)
    rep = {
        "tool": f"octo-gcs {__version__}",
        "created_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "run": {"vehicle_file": os.path.basename(args.vehicle) if getattr(args, "vehicle", None) else None,
                "seed": getattr(args, "seed", None),
                "plant": "octo-sim " + ("real time" if getattr(args, "realtime", False) else "lockstep"),
                "xplane_version": getattr(args, "xplane_version", None),
                "experiments": experiments},
        "bench": {"mass_kg": veh["mass"], "arm_length_m": veh["arm_length"]},
        "truth": {k: _num(v) for k, v in truth.items()},
        "parameters": parameter_rows(nominal, after, truth, experiments),
        "validation": {tag: _validation_params(after, tag) for tag in ("before", "after")},
        "motor_model": [dict(zip(("quantity", "found", "sd", "truth", "error"), r))
                        for r in motor_model_rows(after, veh)],
        "estimator": {k: _num(after.get(k)) for k in sorted(after) if k.startswith("ID_") and not any(
            k in (q.est, q.sd, q.plain) for q in QUANTITIES)},
    }
    if logs is not None:
        val = analysis.validation(logs, after)
        rep["validation"]["from_log"] = [
            {"window": lab, "t_start": _num(t[0], 3), "t_end": _num(t[-1], 3), "ne": _num(n), "fit_pct": _num(f, 3)}
            for lab, t, _c, _m, _p, n, f in val]
        rates = analysis.rate_comparison(logs, after)
        rep["model_fit"] = [
            {"experiment": kind, "t_start": _num(t[0], 3), "t_end": _num(t[-1], 3),
             "fit_pct": {ax: _num(f, 2) for ax, f in zip(("wx", "wy", "wz"), fits)}}
            for kind, t, _w, _wm, fits in rates]
        # the plain estimator's std is only in the log (est_sd[2], est_sd[3]): last value
        from .plots import convergence_series
        conv = convergence_series(logs)
        for key in ("kf", "ktau"):
            row = rep["parameters"][key]
            if row["plain"] is not None and key + "_plain" in conv:
                row["plain_sd"] = _num(float(conv[key + "_plain"][2][-1]), 8)
        rep["_rates"] = rates   # for the figures; removed before writing JSON
        rep["_validation"] = val
        rep["_logs"] = logs
        t_end = logs.truth.t[-1] if logs.truth is not None else (logs.fw.t[-1] if logs.fw is not None else None)
    else:
        t_end = None
    rep["results_from_status_texts"] = list(from_texts)
    checks = plausibility(after, experiments, set(from_texts)) if experiments else []
    checks += against_truth(after, experiments, truth, TOL_ROTOR_PCT, TOL_INERTIA_PCT)
    rep["checks"] = [c.as_dict() for c in checks]
    rep["tolerances_pct"] = {"kf_ktau": TOL_ROTOR_PCT, "inertia": TOL_INERTIA_PCT}
    rep["pass"] = all(c.ok or c.warning for c in checks)
    rep["timing"] = {"simulated_s": _num(t_end, 3), "wall_flight_s": _num(wall_flight_s, 2)}
    return rep


def public(rep):
    """The JSON-writable part of the report."""
    return {k: v for k, v in rep.items() if not k.startswith("_")}


# ---------------------------------------------------------------- rendering
def _f(x, fmt="{:.6g}"):
    return "-" if x is None else fmt.format(x)


def _pct(x):
    return "-" if x is None else f"{x:+.3f} %"


def table_rows(rep):
    """Header and rows of Table 1 beside truth and estimates (strings)."""
    head = ["parameter", "paper (Tab. 1)", "truth", "nominal", "plain LS +/- sd", "err", "lag-aware +/- sd",
            "err", "accepted"]
    rows = []
    for key, r in rep["parameters"].items():
        est = "-" if r["estimate"] is None else f"{r['estimate']:.6g} +/- {r['sd']:.2g}"
        plain = _f(r["plain"])
        if r["plain"] is not None and r.get("plain_sd") is not None:
            plain += f" +/- {r['plain_sd']:.2g}"
        rows.append([f"{r['label']} [{r['unit']}]", _f(r["paper"]), _f(r["truth"]), _f(r["nominal"]),
                     plain, _pct(r["plain_error_pct"]), est, _pct(r["error_pct"]),
                     "yes" if r["accepted"] else "no"])
    return head, rows


def _validation_lines(rep):
    v = rep["validation"]
    lines = []
    b, a = v["before"], v["after"]
    if b["ne"] is not None or a["ne"] is not None:
        lines.append(f"validation (commanded vs measured f_1, firmware): before NE {_f(b['ne'], '{:.4f}')}, "
                     f"fit {_f(b['fit_pct'], '{:.1f}')} %; after NE {_f(a['ne'], '{:.4f}')}, "
                     f"fit {_f(a['fit_pct'], '{:.1f}')} %")
    for w in v.get("from_log", []):
        lines.append(f"validation {w['window']} (from the log): NE {_f(w['ne'], '{:.4f}')}, "
                     f"fit {_f(w['fit_pct'], '{:.1f}')} %")
    for m in rep.get("model_fit", []):
        ax, name = {"ixx": ("wx", "I_x"), "iyy": ("wy", "I_y"), "izz": ("wz", "I_z")}[m["experiment"]]
        lines.append(f"omega_{ax[1]} vs the analytical model with the estimates ({name} experiment): "
                     f"fit {_f(m['fit_pct'][ax], '{:.1f}')} %")
    return lines


def table_text(rep):
    head, rows = table_rows(rep)
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    fmt = "  ".join("{:<%d}" % w for w in widths)
    out = [fmt.format(*head), fmt.format(*["-" * w for w in widths])]
    out += [fmt.format(*r) for r in rows]
    out += [""] + _validation_lines(rep)
    out += [""] + _motor_lines(rep)
    return "\n".join(out)


def _motor_lines(rep):
    """The motor model found beside the truth, as an aligned text table."""
    rows = [("motor model", "found", "sd", "truth", "error")] + [
        (r["quantity"], r["found"], r["sd"], r["truth"], r["error"]) for r in rep.get("motor_model", [])]
    widths = [max(len(str(x)) for x in col) for col in zip(*rows)]
    fmt = "  ".join("{:<%d}" % w for w in widths)
    return [fmt.format(*r) for r in rows]


def markdown(rep, figures=()):
    head, rows = table_rows(rep)
    run = rep["run"]
    vname = run["vehicle_file"] or "the paper's (defaults)"
    lines = [
        "# Octo-SIL identification report", "",
        f"{rep['tool']}, {rep['created_utc']}. Plant: {run['plant']} (X-Plane {run['xplane_version']} "
        f"protocol), seed {run['seed']}, vehicle {vname}; "
        f"bench values given to the firmware: mass {rep['bench']['mass_kg']:g} kg, "
        f"arm length {rep['bench']['arm_length_m']:g} m.", "",
        "## Table 1 beside the truth and the estimates", "",
        "| " + " | ".join(head) + " |", "|" + "---|" * len(head),
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    lines += ["",
              "*paper*: Table 1 of de Castro et al. (their X-Plane octocopter). *truth*: the simulated "
              "vehicle. *nominal*: the firmware's values before identification. *plain LS*: the paper's "
              "least squares of measured f_1, tau_1 on the commanded T_1 (eqs. 18-20), biased by the "
              "motor lag. *lag-aware*: regression on the command passed through the motor model, with "
              "its standard deviation. Errors are relative to the truth.", ""]
    lines += ["## Validation", ""] + [f"- {x}" for x in _validation_lines(rep)] + [""]
    mm = rep.get("motor_model", [])
    if mm:
        lines += ["## Motor model found in flight", "", "| quantity | found | sd | truth | error |",
                  "|---|---|---|---|---|"]
        lines += [f"| {r['quantity']} | {r['found']} | {r['sd']} | {r['truth']} | {r['error']} |" for r in mm]
        lines += ["", "Found by the rotor experiment (transport delay, motor lag, thrust curve and each "
                  "rotor's effectiveness, median 1); applied only when accepted.", ""]
    lines += ["## Checks", ""]
    for c in rep["checks"]:
        tag = "ok" if c["ok"] else ("warning" if c["warning_only"] else "**FAILED**")
        lines.append(f"- {tag}: {c['check']}: {c['detail']}")
    lines += ["", f"Overall: **{'PASS' if rep['pass'] else 'FAIL'}** (tolerances: k_f, k_tau "
              f"{rep['tolerances_pct']['kf_ktau']} %, inertia {rep['tolerances_pct']['inertia']} %).", ""]
    if figures:
        lines += ["## Figures", ""]
        captions = {
            "fig5_excitation.png": "Fig. 5: the excitation delta_1 (rotor 1 throttle) and mu_1 (torque).",
            "fig6_validation.png": "Fig. 6: commanded vs measured f_1, (a) before and (b) after identification.",
            "fig7_rates.png": "Fig. 7: body rates, simulator vs the analytical model with the estimates.",
            "convergence.png": "Estimates +/- 2 sigma over time; truth dashed.",
        }
        for f in figures:
            lines += [f"![{f}]({f})", "", captions.get(f, ""), ""]
    t = rep["timing"]
    lines += ["## Run", "", f"- simulated time: {_f(t.get('simulated_s'), '{:.1f}')} s; "
              f"flight wall time: {_f(t.get('wall_flight_s'), '{:.1f}')} s", ""]
    return "\n".join(lines)


def write_outputs(stage, rep, plots=True):
    """report.md and the figures into `stage` (report.json is written by the caller)."""
    figures = []
    if plots and rep.get("_logs") is not None:
        from .plots import make_figures
        figures = make_figures(rep["_logs"], rep, stage)
    rep["figures"] = figures
    atomic_write(os.path.join(stage, "report.md"), markdown(rep, figures))
    return figures


def dumps(rep):
    return json.dumps(public(rep), indent=2, allow_nan=False) + "\n"
