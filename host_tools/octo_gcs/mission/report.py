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

from .. import __version__, id_results
from ..atomicfile import atomic_write
from ..checks import (
    TOL_RATIO_PCT,
    Check,
    against_truth,
    has_ratio,
    motor_model_rows,
    not_identifiable_checks,
    plausibility,
    ratio_checks,
    ratio_row,
    unidentifiable,
)
from ..quantities import QUANTITIES, quantities_of
from ..vehiclefile import PAPER, truth_of

PAPER_VALUES = {
    "kf": PAPER["kf"],
    "ktau": PAPER["ktau"],
    "ixx": PAPER["inertia"][0],
    "iyy": PAPER["inertia"][1],
    "izz": PAPER["inertia"][2],
}

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


# the experiment phase whose data each estimate comes from (the firmware's "ID k/n: <phase>")
ESTIMATE_PHASE = {
    "kf": "rotor",
    "ktau": "rotor",
    "ixx": "inertia ixx",
    "iyy": "inertia iyy",
    "izz": "inertia izz",
}


def truth_windows(logs):
    """{quantity: (t_start, t_end)} of the experiment phase each estimate comes from (the last
    such phase in the log), from the firmware's events."""
    out = {}
    if logs is None:
        return out
    for key, word in ESTIMATE_PHASE.items():
        w = logs.phase_windows(word)
        if w:
            out[key] = (float(w[-1][1]), float(w[-1][2]))
    return out


def truth_from_logs(logs, veh, windows=None):
    """The truth each estimate is compared with: the vehicle file, or from the truth log at the
    same simulated time as the estimate, the mean over the experiment phase its data come from
    (a drifting k_f: the estimate is a fit over that phase); without a phase, the log's end
    (the middle when k_f drifts)."""
    t = truth_of(veh)
    if logs is not None and logs.truth is not None and len(logs.truth):
        tr = logs.truth
        t = {
            "kf": float(tr.kf[-1]),
            "ktau": float(tr.ktau[-1]),
            "ixx": float(tr.inertia[-1, 0]),
            "iyy": float(tr.inertia[-1, 1]),
            "izz": float(tr.inertia[-1, 2]),
        }
        if abs(tr.kf[-1] - tr.kf[0]) > 1e-9 * tr.kf[0]:
            i = len(tr) // 2
            t["kf"], t["ktau"] = float(tr.kf[i]), float(tr.ktau[i])
        series = {
            "kf": tr.kf,
            "ktau": tr.ktau,
            "ixx": tr.inertia[:, 0],
            "iyy": tr.inertia[:, 1],
            "izz": tr.inertia[:, 2],
        }
        for key, (t0, t1) in (windows if windows is not None else truth_windows(logs)).items():
            sel = (tr.t >= t0) & (tr.t <= t1)
            if sel.any():
                t[key] = float(series[key][sel].mean())
    return t


KFT_SAMPLE_S = 5.0  # the tracked k_f in the report: one sample every this many seconds
KFT_WARM_S = 10.0  # ... compared (check) from this long after the rotor model is final
KFT_TOL_PCT = 0.3


def kf_tracked(logs, kf_sd_pct=None):
    """The k_f the firmware tracked (fw log: kft, kft_sd, while it updates: HOLD and
    experiments) against the truth log's k_f at the same simulated time: samples every
    KFT_SAMPLE_S and a summary over those from KFT_WARM_S after the rotor experiment (the
    rotor model it finds restarts the tracker) or after the tracker's first value. The tracker
    regresses on the identified rotor model: its k_f (thrust at FULL throttle, extrapolated
    from hover through the thrust curve) carries the curve's error as the identified k_f does,
    so the limit is that of the identified k_f (KFT_TOL_PCT or 4 of its sd, kf_sd_pct), and a
    frame is beyond it only if it is also beyond 4 of the tracked k_f's own published sd
    (KFT_SD: absolute, the identified model's error and the tracking's together; the tracking
    adds its own to the identified error, so the identified sd alone understates it). The drift
    itself is compared apart: the tracked change over the compared window against the truth's."""
    import numpy as np

    if logs is None or logs.fw is None or logs.truth is None or not logs.fw.has("kft"):
        return None
    fw, tr = logs.fw, logs.truth
    on = (fw.kft > 0) & ((fw.mode == 3) | (fw.mode == 4)) & fw.stepped
    if not on.any():
        return None
    t = fw.t[on]
    true = np.interp(t, tr.t, tr.kf)
    est, sd = fw.kft[on], fw.kft_sd[on]
    err = 100.0 * (est - true) / true
    # the error over the tracked k_f's own sd (absolute: it carries the identified model's)
    z = np.where(sd > 0, (est - true) / np.where(sd > 0, sd, 1.0), np.nan)
    rotor = truth_windows(logs).get("kf")
    t_from = (rotor[1] if rotor else float(t[0])) + KFT_WARM_S
    samples, t_next = [], float(t[0])
    for i in range(len(t)):
        if t[i] >= t_next:
            samples.append(
                {
                    "t": _num(t[i], 3),
                    "estimate": _num(est[i]),
                    "sd": _num(sd[i], 8),
                    "truth": _num(true[i]),
                    "error_pct": _num(err[i], 4),
                    "error_over_sd": _num(z[i], 3),
                    "compared": bool(t[i] >= t_from),
                }
            )
            t_next = float(t[i]) + KFT_SAMPLE_S
    w = t >= t_from
    cmp_ = err[w]
    limit = max(KFT_TOL_PCT, 4.0 * kf_sd_pct) if kf_sd_pct else KFT_TOL_PCT
    summary = {
        "from_t": _num(t_from, 3),
        "samples": int(len(cmp_)),
        "max_abs_error_pct": _num(float(np.abs(cmp_).max()), 4) if len(cmp_) else None,
        "rms_error_pct": _num(float(np.sqrt(np.mean(cmp_**2))), 4) if len(cmp_) else None,
        "limit_pct": _num(limit, 4),
        # beyond the limit and beyond 4 of the tracked k_f's own sd (which carries the
        # identified model's error and the tracking's): what the warning counts
        "beyond_limit": int(np.sum((np.abs(cmp_) > limit) & ~(np.abs(z[w]) <= 4.0))),
        "max_abs_error_over_sd": _num(float(np.nanmax(np.abs(z[w]))), 3) if np.isfinite(z[w]).any() else None,
        "rms_error_over_sd": _num(float(np.sqrt(np.nanmean(z[w] ** 2))), 3)
        if np.isfinite(z[w]).any()
        else None,
        "truth_change_pct": _num(100.0 * (true[-1] / true[0] - 1), 4),
    }
    if w.sum() > 1:
        e, tt = est[w], true[w]
        summary["drift_tracked_pct"] = _num(100.0 * (e[-1] / e[0] - 1), 4)
        summary["drift_truth_pct"] = _num(100.0 * (tt[-1] / tt[0] - 1), 4)
    return {"summary": summary, "samples": samples}


def ratio_truth(logs, veh, windows=None):
    """The truth of k_tau / I_z: the truth log's mean of k_tau / I_z over the yaw inertia
    phase (the ratio's data; k_tau drifts with k_f), else at the log's end, else the vehicle
    file's."""
    t = truth_of(veh)
    if logs is None or logs.truth is None or not len(logs.truth):
        return t["ktau"] / t["izz"]
    tr = logs.truth
    r = tr.ktau / tr.inertia[:, 2]
    w = (windows if windows is not None else truth_windows(logs)).get("izz")
    if w:
        sel = (tr.t >= w[0]) & (tr.t <= w[1])
        if sel.any():
            return float(r[sel].mean())
    return float(r[-1])


# what the validation compares (the paper's mu_1 test), by the source of the rotor model
VALIDATION_WORDS = {
    "thrust": "commanded vs measured f_1",
    "imu": "measured collective force m g a_z vs the modelled thrusts' sum",
}


def validation_words(source):
    """The validation's comparison in words for `source` (thrust rows: rotor 1's thrust)."""
    if source and source != "thrust":
        return VALIDATION_WORDS["imu"]
    return VALIDATION_WORDS["thrust"]


def parameter_rows(nominal, after, truth, experiments, results=(), unident=()):
    """Table 1's rows. unident: the quantities the source cannot determine alone: no estimate,
    reported as not identifiable (never as a failure, never with a value)."""
    rows = {}
    ident = {q.key for q in quantities_of(experiments)}
    verdicts = id_results.verdicts(results)
    source = id_results.estimator_source(results)
    for q in QUANTITIES:
        if q.key in ident and q.key in unident:
            true = truth.get(q.key) if truth else None
            rows[q.key] = {
                "label": q.label,
                "unit": q.unit,
                "paper": PAPER_VALUES[q.key],
                "truth": _num(true),
                "nominal": _num(nominal.get(q.veh)),
                "plain": None,
                "plain_error_pct": None,
                "estimate": None,
                "sd": None,
                "sd_pct": None,
                "error_pct": None,
                "error_over_sd": None,
                "accepted": False,
                "vehicle_value": _num(after.get(q.veh)),
                "identifiable": False,
                "reason": id_results.NOT_IDENTIFIABLE,
                "source": source,
            }
            continue
        est = after.get(q.est) if q.key in ident else None
        est = est if est is not None and est > 0 else None
        sd = after.get(q.sd) if est is not None else None
        plain = after.get(q.plain) if (q.plain and est is not None) else None
        plain = plain if plain is not None and plain > 0 else None
        true = truth.get(q.key) if truth else None
        row = {
            "label": q.label,
            "unit": q.unit,
            "paper": PAPER_VALUES[q.key],
            "truth": _num(true),
            "nominal": _num(nominal.get(q.veh)),
            "plain": _num(plain),
            "plain_error_pct": _num(_err(plain, true), 4),
            "estimate": _num(est),
            "sd": _num(sd, 8),
            "sd_pct": _num(100.0 * sd / est if est and sd is not None else None, 4),
            "error_pct": _num(_err(est, true), 4),
            "error_over_sd": _num((est - true) / sd if est and sd and true else None, 3),
            "accepted": bool(int(after.get("ID_RESULT", 0)) & q.bit)
            and verdicts.get(q.key, {}).get("accepted", True)
            if est is not None
            else False,
            "vehicle_value": _num(after.get(q.veh)),
            # the firmware's result record: why it was not accepted, what it rests on
            "reason": verdicts[q.key]["reason"] if q.key in verdicts and est is not None else None,
            "source": verdicts[q.key]["source"] if q.key in verdicts and est is not None else None,
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


def build_report(
    stage, veh, opts, nominal, after, experiments, wall_flight_s=None, logs=None, filled=(), results=()
):
    """The report dict of a mission whose files are in `stage`: opts its MissionOptions,
    results the firmware's identification results (id_results.record dicts), filled the
    names of `after` that only those carried."""
    from ..logs import Logs

    if logs is None:
        paths = [
            p for p in (os.path.join(stage, "truth.lcm"), os.path.join(stage, "fw.lcm")) if os.path.exists(p)
        ]
        logs = Logs(paths) if paths else None
    windows = truth_windows(logs)
    truth = truth_from_logs(logs, veh, windows)
    source = id_results.estimator_source(results)
    # the quantities the source cannot determine alone: the firmware's own word (its records;
    # without records, what its source and ID_IZZ_PRI_SD imply), checked against each other below
    stated = id_results.not_identifiable(results) if experiments else set()
    expected = unidentifiable(_with_source(after, source)) if experiments else set()
    unident = stated if results else expected
    rep = {
        "tool": f"octo-gcs {__version__}",
        "created_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "run": {
            "vehicle_file": os.path.basename(opts.vehicle) if getattr(opts, "vehicle", None) else None,
            "seed": getattr(opts, "seed", None),
            "plant": "octo-sim " + ("real time" if getattr(opts, "realtime", False) else "lockstep"),
            "xplane_version": getattr(opts, "xplane_version", None),
            "experiments": experiments,
            "build": getattr(opts, "build", "float"),
            "sensors": getattr(opts, "sensors", None),  # None: the plant's default (all)
            "start_time_s": getattr(opts, "start_time", 0.0),
            "shift_origin_s": list(getattr(opts, "shift_origin", []) or []),
        },
        "bench": {"mass_kg": veh["mass"], "arm_length_m": veh["arm_length"]},
        "truth": {k: _num(v) for k, v in truth.items()},
        "truth_window_s": {k: [_num(a, 3), _num(b, 3)] for k, (a, b) in windows.items()},
        "parameters": parameter_rows(nominal, after, truth, experiments, results, unident),
        "validation": {tag: _validation_params(after, tag) for tag in ("before", "after")},
        "motor_model": [
            dict(zip(("quantity", "found", "sd", "truth", "error"), r))
            for r in motor_model_rows(after, veh, source)
        ],
        "estimator": {
            k: _num(after.get(k))
            for k in sorted(after)
            if k.startswith("ID_") and not any(k in (q.est, q.sd, q.plain) for q in QUANTITIES)
        },
        "id_results": [id_results.describe(r) for r in results],
    }
    rep["estimator"]["source"] = source
    if source and source != "thrust":
        rep["validation"]["compares"] = validation_words(source)
    ratio = None
    if experiments and "izz" in unident and has_ratio(_with_source(after, source), experiments):
        ratio = ratio_row(after, id_results.ratio_verdict(results), ratio_truth(logs, veh, windows))
        ratio = {k: (_num(v) if isinstance(v, float) else v) for k, v in ratio.items()}
        ratio["source"] = source
        rep["ktau_over_izz"] = ratio
    t_end = _from_logs(rep, logs, after, nominal, source) if logs is not None else None
    rep["results_from_records"] = list(filled)
    verdicts = id_results.verdicts(results)
    checks = plausibility(after, experiments, unident, verdicts) if experiments else []
    checks += against_truth(after, experiments, truth, TOL_ROTOR_PCT, TOL_INERTIA_PCT, unident)
    if stated or expected:
        checks += not_identifiable_checks(after, nominal, stated, expected, source)
    if ratio is not None:
        checks += ratio_checks(ratio)
    checks += (
        _source_checks(rep["estimator"]["source"], getattr(opts, "sensors", None)) if experiments else []
    )
    kft = kf_tracked(logs, rep["parameters"]["kf"]["sd_pct"] if "kf" in rep["parameters"] else None)
    if kft is not None:
        rep["kf_tracked"] = kft
        checks += _kf_tracked_checks(kft["summary"])
    rep["checks"] = [c.as_dict() for c in checks]
    rep["tolerances_pct"] = {"kf_ktau": TOL_ROTOR_PCT, "inertia": TOL_INERTIA_PCT}
    if ratio is not None:
        rep["tolerances_pct"]["ktau_over_izz"] = TOL_RATIO_PCT
    rep["pass"] = all(c.ok or c.warning for c in checks)
    rep["timing"] = {"simulated_s": _num(t_end, 3), "wall_flight_s": _num(wall_flight_s, 2)}
    return rep


def _with_source(after, source):
    """`after` with ID_SRC_USED from the records' source when the parameters lack it."""
    if "ID_SRC_USED" in after or not source:
        return after
    code = {"thrust": 1, "imu": 2, "imu_rpm": 3, "imu_rpm_torque": 4}.get(source)
    return dict(after, ID_SRC_USED=float(code)) if code else after


def _from_logs(rep, logs, after, nominal=None, source=None):
    """What the report takes from the logs: the validation and the rates' fit recomputed, the
    plain estimates' sd, what the figures need; returns the simulated time at the end."""
    from .. import analysis
    from ..plots import convergence_series

    if source and source != "thrust":
        val = analysis.validation_collective(logs, after, nominal)
    else:
        val = analysis.validation(logs, after)
    rep["validation"]["from_log"] = [
        {
            "window": lab,
            "t_start": _num(t[0], 3),
            "t_end": _num(t[-1], 3),
            "ne": _num(n),
            "fit_pct": _num(f, 3),
        }
        for lab, t, _c, _m, _p, n, f in val
    ]
    rates = analysis.rate_comparison(logs, after)
    rep["model_fit"] = [
        {
            "experiment": kind,
            "t_start": _num(t[0], 3),
            "t_end": _num(t[-1], 3),
            "fit_pct": {ax: _num(f, 2) for ax, f in zip(("wx", "wy", "wz"), fits)},
        }
        for kind, t, _w, _wm, fits in rates
    ]
    # the plain estimator's std is only in the log (est_sd[2], est_sd[3]): last value
    conv = convergence_series(logs)
    for key in ("kf", "ktau"):
        row = rep["parameters"].get(key)
        if row is not None and row["plain"] is not None and key + "_plain" in conv:
            row["plain_sd"] = _num(float(conv[key + "_plain"][2][-1]), 8)
    rep["_rates"] = rates  # for the figures; removed before writing JSON
    rep["_validation"] = val
    rep["_logs"] = logs
    return logs.truth.t[-1] if logs.truth is not None else (logs.fw.t[-1] if logs.fw is not None else None)


def _source_checks(source, served):
    """The measurements the estimates rest on were served by the plant (with --sensors)."""
    need = id_results.SOURCE_SENSORS.get(source or "")
    if served is None or need is None:
        return []
    missing = [x for x in need if x not in served]
    detail = f"estimated from {id_results.source_words(source)} (source {source}); the plant served {','.join(served)}"
    if missing:
        detail += f": {', '.join(missing)} not served"
    return [Check("estimates rest on the sensors served", not missing, detail)]


def _kf_tracked_checks(s_):
    """The tracked k_f against the truth, and its drift (warnings only)."""
    checks = []
    if s_["samples"]:
        checks.append(
            Check(
                "k_f tracked vs truth at the same time",
                s_["beyond_limit"] == 0,
                f"max {s_['max_abs_error_pct']:.3f} %, rms {s_['rms_error_pct']:.3f} % over "
                f"{s_['samples']} frames from t={s_['from_t']:.1f} s, {s_['beyond_limit']} beyond "
                f"{s_['limit_pct']:.3g} % (the identified k_f's limit) and 4 of the tracked k_f's own sd",
                warning=True,
            )
        )
        if s_.get("drift_truth_pct") is not None:
            d = s_["drift_tracked_pct"] - s_["drift_truth_pct"]
            checks.append(
                Check(
                    "k_f drift tracked",
                    abs(d) <= KFT_TOL_PCT,
                    f"{s_['drift_tracked_pct']:+.3f} % tracked, {s_['drift_truth_pct']:+.3f} % "
                    f"true (limit {KFT_TOL_PCT} %)",
                    warning=True,
                )
            )
    return checks


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
    head = [
        "parameter",
        "paper (Tab. 1)",
        "truth",
        "nominal",
        "plain LS +/- sd",
        "err",
        "lag-aware +/- sd",
        "err",
        "accepted",
    ]
    rows = []
    for key, r in rep["parameters"].items():
        if r.get("identifiable") is False:
            rows.append(
                [
                    f"{r['label']} [{r['unit']}]",
                    _f(r["paper"]),
                    _f(r["truth"]),
                    _f(r["nominal"]),
                    "-",
                    "-",
                    "-",
                    "-",
                    "not identifiable from the gyro alone",
                ]
            )
            continue
        est = "-" if r["estimate"] is None else f"{r['estimate']:.6g} +/- {r['sd']:.2g}"
        plain = _f(r["plain"])
        if r["plain"] is not None and r.get("plain_sd") is not None:
            plain += f" +/- {r['plain_sd']:.2g}"
        rows.append(
            [
                f"{r['label']} [{r['unit']}]",
                _f(r["paper"]),
                _f(r["truth"]),
                _f(r["nominal"]),
                plain,
                _pct(r["plain_error_pct"]),
                est,
                _pct(r["error_pct"]),
                "yes" if r["accepted"] else ("no: " + r["reason"] if r.get("reason") else "no"),
            ]
        )
    x = rep.get("ktau_over_izz")
    if x is not None:
        paper = PAPER_VALUES["ktau"] / PAPER_VALUES["izz"]
        nom = [rep["parameters"].get(k, {}).get("nominal") for k in ("ktau", "izz")]
        rows.append(
            [
                f"{x['label']} [{x['unit']}]",
                _f(paper),
                _f(x["truth"]),
                _f(nom[0] / nom[1] if all(nom) else None),
                "-",
                "-",
                "-" if x["estimate"] is None else f"{x['estimate']:.6g} +/- {_f(x['sd'], '{:.2g}')}",
                _pct(x["error_pct"]),
                "yes" if x["accepted"] else ("no: " + x["reason"] if x.get("reason") else "no"),
            ]
        )
    return head, rows


def _validation_lines(rep):
    v = rep["validation"]
    lines = []
    b, a = v["before"], v["after"]
    words = v.get("compares") or validation_words("thrust")
    if b["ne"] is not None or a["ne"] is not None:
        lines.append(
            f"validation ({words}, firmware): before NE {_f(b['ne'], '{:.4f}')}, "
            f"fit {_f(b['fit_pct'], '{:.1f}')} %; after NE {_f(a['ne'], '{:.4f}')}, "
            f"fit {_f(a['fit_pct'], '{:.1f}')} %"
        )
    for w in v.get("from_log", []):
        lines.append(
            f"validation {w['window']} ({words + ', ' if v.get('compares') else ''}from the log): "
            f"NE {_f(w['ne'], '{:.4f}')}, "
            f"fit {_f(w['fit_pct'], '{:.1f}')} %"
        )
    for m in rep.get("model_fit", []):
        ax, name = {"ixx": ("wx", "I_x"), "iyy": ("wy", "I_y"), "izz": ("wz", "I_z")}[m["experiment"]]
        lines.append(
            f"omega_{ax[1]} vs the analytical model with the estimates ({name} experiment): "
            f"fit {_f(m['fit_pct'][ax], '{:.1f}')} %"
        )
    return lines


def source_line(rep):
    """'Estimated from: thrust rows (source thrust)': the measurements the estimates rest on, as
    the firmware's identification results state it."""
    name = (rep.get("estimator") or {}).get("source")
    if not name:
        return "Estimated from: not stated (no identification result gave its source)"
    return f"Estimated from: {id_results.source_words(name)} (source {name})"


def run_words(run):
    """The build and what the plant was asked beyond its defaults, for report.md's first lines."""
    words = [f"firmware build {run.get('build') or 'float'}"]
    sensors = run.get("sensors")
    words.append("sensors served: " + (",".join(sensors) if sensors else "all"))
    if run.get("start_time_s"):
        words.append(f"plant clock from {run['start_time_s']:g} s")
    if run.get("shift_origin_s"):
        words.append("origin shifts at " + ", ".join(f"{t:g}" for t in run["shift_origin_s"]) + " s")
    return "; ".join(words)


def table_text(rep):
    head, rows = table_rows(rep)
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows)]
    fmt = "  ".join("{:<%d}" % w for w in widths)
    out = [source_line(rep), ""]
    out += [fmt.format(*head), fmt.format(*["-" * w for w in widths])]
    out += [fmt.format(*r) for r in rows]
    note = _unidentifiable_note(rep)
    if note:
        out += ["", note]
    out += [""] + _validation_lines(rep)
    out += [""] + _motor_lines(rep)
    return "\n".join(out)


def _unidentifiable_note(rep):
    """The line under Table 1 naming what the source cannot determine alone ("" when nothing)."""
    names = [r["label"] for r in rep["parameters"].values() if r.get("identifiable") is False]
    if not names:
        return ""
    src = (rep.get("estimator") or {}).get("source") or "?"
    what = " and ".join(names)
    if "ktau_over_izz" not in rep:
        how = "no ratio was identified"
    elif len(names) > 1:
        how = "their ratio k_tau/I_z is identified, no value of either"
    else:
        how = "the ratio k_tau/I_z is identified, k_tau from it with the prior on I_z (ID_IZZ_PRI_SD)"
    return f"{what}: not identifiable from the gyro alone (source {src}, no ESC torque): {how}."


def _motor_lines(rep):
    """The motor model found beside the truth, as an aligned text table."""
    rows = [("motor model", "found", "sd", "truth", "error")] + [
        (r["quantity"], r["found"], r["sd"], r["truth"], r["error"]) for r in rep.get("motor_model", [])
    ]
    widths = [max(len(str(x)) for x in col) for col in zip(*rows)]
    fmt = "  ".join("{:<%d}" % w for w in widths)
    return [fmt.format(*r) for r in rows]


def _kf_tracked_md(kft):
    """report.md's section on the tracked k_f (none without it)."""
    lines = []
    if not kft:
        return lines
    s_ = kft["summary"]
    lines += ["## k_f tracked against the truth at the same simulated time", ""]
    if s_["samples"]:
        lines += [
            f"From t = {s_['from_t']:.1f} s ({KFT_WARM_S:g} s after the rotor model is final): "
            f"max |error| {s_['max_abs_error_pct']:.3f} %, rms {s_['rms_error_pct']:.3f} % over "
            f"{s_['samples']} frames (limit {s_['limit_pct']:.3g} %: the tracker regresses on the "
            "identified rotor model, so its k_f at full throttle carries the thrust curve's "
            f"error as the identified k_f does; {s_['beyond_limit']} frames beyond it and 4 of the tracked "
            "sd); drift over that window "
            f"{s_.get('drift_tracked_pct', float('nan')):+.3f} % tracked, "
            f"{s_.get('drift_truth_pct', float('nan')):+.3f} % true; the truth changed "
            f"{s_['truth_change_pct']:+.3f} % over the whole tracking.",
            "",
        ]
        if s_.get("max_abs_error_over_sd") is not None:
            lines += [
                "The tracked sd (KFT_SD) is absolute: the tracking's combined with the identified k_f's "
                f"(docs/identification.md). Error over that sd: rms {s_['rms_error_over_sd']:.2f}, "
                f"max {s_['max_abs_error_over_sd']:.2f}.",
                "",
            ]
    lines += [
        "| t [s] | tracked k_f [N] | sd | truth [N] | error | error / sd |",
        "|---|---|---|---|---|---|",
    ]
    lines += [
        f"| {x['t']:.1f} | {x['estimate']:.5g} | {x['sd']:.2g} | {x['truth']:.5g} | "
        f"{x['error_pct']:+.3f} %{'' if x['compared'] else ' (warming up)'} | "
        f"{'-' if x.get('error_over_sd') is None else format(x['error_over_sd'], '+.2f')} |"
        for x in kft["samples"]
    ]
    lines += [""]
    return lines


def markdown(rep, figures=()):
    head, rows = table_rows(rep)
    run = rep["run"]
    vname = run["vehicle_file"] or "the paper's (defaults)"
    lines = [
        "# Octo-SIL identification report",
        "",
        f"{rep['tool']}, {rep['created_utc']}. Plant: {run['plant']} (X-Plane {run['xplane_version']} "
        f"protocol), seed {run['seed']}, vehicle {vname}; "
        f"bench values given to the firmware: mass {rep['bench']['mass_kg']:g} kg, "
        f"arm length {rep['bench']['arm_length_m']:g} m; {run_words(run)}.",
        "",
        source_line(rep) + ".",
        "",
        "## Table 1 beside the truth and the estimates",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    lines += [
        "",
        "*paper*: Table 1 of de Castro et al. (their X-Plane octocopter). *truth*: the simulated "
        "vehicle. *nominal*: the firmware's values before identification. *plain LS*: the paper's "
        "least squares of measured f_1, tau_1 on the commanded T_1 (eqs. 18-20), biased by the "
        "motor lag. *lag-aware*: regression on the command passed through the motor model, with "
        "its standard deviation. Errors are relative to the truth at the same simulated time: "
        "the truth log's mean over the experiment phase the estimate comes from "
        + ", ".join(f"{k} {w[0]:.1f}-{w[1]:.1f} s" for k, w in rep.get("truth_window_s", {}).items())
        + ".",
        "",
    ]
    x = rep.get("ktau_over_izz")
    if x is not None:
        lines += [
            f"*Source {x.get('source')}*: the gyro sees the yaw torque only through k_tau / I_z, so "
            "k_tau and I_z are not identifiable alone and no value of either is given; their ratio "
            "is identified, with its sd, and compared with the truth log's k_tau / I_z over the "
            f"yaw phase (limit max(3 sd, {TOL_RATIO_PCT:g} %)). A prior on I_z (VEH_IZZ, with its "
            "relative sd in ID_IZZ_PRI_SD) turns the ratio into k_tau.",
            "",
        ]
    lines += _kf_tracked_md(rep.get("kf_tracked"))
    lines += ["## Validation", ""] + [f"- {x}" for x in _validation_lines(rep)] + [""]
    mm = rep.get("motor_model", [])
    if mm:
        lines += [
            "## Motor model found in flight",
            "",
            "| quantity | found | sd | truth | error |",
            "|---|---|---|---|---|",
        ]
        lines += [f"| {r['quantity']} | {r['found']} | {r['sd']} | {r['truth']} | {r['error']} |" for r in mm]
        source = (rep.get("estimator") or {}).get("source")
        if source in (None, "thrust"):
            what = "transport delay, motor lag, thrust curve and each rotor's effectiveness, median 1"
        else:
            what = (
                "transport delay, motor lag and thrust curve from the accelerometer; it sees the "
                "rotors' sum, so each rotor's effectiveness is not identified: the flight assumed "
                "MOT_SCALE, and a rotor off it is a rejection naming the cause"
            )
        lines += ["", f"Found by the rotor experiment ({what}); applied only when accepted.", ""]
    lines += ["## Checks", ""]
    for c in rep["checks"]:
        tag = "ok" if c["ok"] else ("warning" if c["warning_only"] else "**FAILED**")
        lines.append(f"- {tag}: {c['check']}: {c['detail']}")
    lines += [
        "",
        f"Overall: **{'PASS' if rep['pass'] else 'FAIL'}** (tolerances: k_f, k_tau "
        f"{rep['tolerances_pct']['kf_ktau']} %, inertia {rep['tolerances_pct']['inertia']} %"
        + (
            f", k_tau/I_z {rep['tolerances_pct']['ktau_over_izz']} % or 3 sd"
            if "ktau_over_izz" in rep["tolerances_pct"]
            else ""
        )
        + ").",
        "",
    ]
    if figures:
        lines += ["## Figures", ""]
        captions = {
            "fig5_excitation.png": "Fig. 5: the excitation delta_1 (rotor 1 throttle) and mu_1 (torque).",
            "fig6_validation.png": f"Fig. 6: {rep['validation'].get('compares') or 'commanded vs measured f_1'}, "
            "(a) before and (b) after identification.",
            "fig7_rates.png": "Fig. 7: body rates, simulator vs the analytical model with the estimates.",
            "convergence.png": "Each identification result (the applied estimate) +/- 2 sd beside the live "
            "estimates in flight (auxiliary); truth dashed.",
        }
        for f in figures:
            lines += [f"![{f}]({f})", "", captions.get(f, ""), ""]
    t = rep["timing"]
    lines += [
        "## Run",
        "",
        f"- simulated time: {_f(t.get('simulated_s'), '{:.1f}')} s; "
        f"flight wall time: {_f(t.get('wall_flight_s'), '{:.1f}')} s",
        "",
    ]
    return "\n".join(lines)


def write_outputs(stage, rep, plots=True):
    """report.md and the figures into `stage` (report.json is written by the caller)."""
    figures = []
    if plots and rep.get("_logs") is not None:
        from ..plots import make_figures

        figures = make_figures(rep["_logs"], rep, stage)
    rep["figures"] = figures
    atomic_write(os.path.join(stage, "report.md"), markdown(rep, figures))
    return figures


def dumps(rep):
    return json.dumps(public(rep), indent=2, allow_nan=False) + "\n"
