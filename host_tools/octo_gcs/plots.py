"""The report's figures (matplotlib, Agg backend), after the paper's Figures 5, 6, 7.

- fig5_excitation.png: delta_1 (added to rotor 1's throttle, rotor experiment) and
  mu_1 (added to the demanded torque, validation), over time.
- fig6_validation.png: commanded f_bar_1 vs measured f_1, (a) before and (b) after
  identification.
- fig7_rates.png: body rates of the simulator vs the analytical model (eqs. 1-10,
  RK4, estimated parameters, same throttles) during the inertia experiments.
- convergence.png: each quantity's identification result (the estimate that is applied, from
  report.json's parameters or the log's OCTO_ID_RESULT records) +/- 2 sd, beside the live
  recursive estimate in flight, labelled as the auxiliary it is; truth dashed.

Every figure is written atomically (temporary name, then rename). A figure whose
data is missing from the logs says so inside the figure instead of failing.
"""

import os
import tempfile

import numpy as np

from . import analysis

FIGURES = ("fig5_excitation.png", "fig6_validation.png", "fig7_rates.png", "convergence.png")

# est[] slots of OCTO_FW_FRAME (firmware/app/experiment.c, the same in every experiment):
# est[i] and est_sd[i]; slot 7 is the validation's NE (its est_sd: the fit %)
EST_SLOTS = {"kf": 0, "ktau": 1, "kf_plain": 2, "ktau_plain": 3, "ixx": 4, "iyy": 5, "izz": 6}
EST_PHASE = {
    "kf": "rotor",
    "ktau": "rotor",
    "kf_plain": "rotor",
    "ktau_plain": "rotor",
    "ixx": "ixx",
    "iyy": "iyy",
    "izz": "izz",
}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path):
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".png", dir=d)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        from .atomicfile import file_mode

        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _empty(ax, text):
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="0.4")
    ax.set_xticks([])
    ax.set_yticks([])


def excitation_torque(w):
    """The torque the experiment added to the demand (mu_1 in validation, the inertia
    excitation): what the allocation delivers minus the hover control's demand."""
    for name in ("mu", "mu_1", "tau_exc", "tau_delta"):
        if w.has(name):
            v = np.asarray(getattr(w, name))
            return v if v.ndim == 2 else np.column_stack([v, 0 * v, 0 * v])
    return w.tau_alloc - w.tau_dem


def fig5(logs, path, plt):
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5.5))
    fw = logs.fw
    ph = analysis.phases(logs) if fw is not None else {}
    rot = ph.get("rotor", [])
    if fw is not None and rot:
        t0, t1 = rot[0]
        w = analysis.window(fw, t0, t1)
        a1.plot(w.t - t0, w.excitation[:, 0], lw=0.6, color="C0")
        a1.set_ylabel("delta_1 (throttle)")
        a1.set_title(
            f"delta_1: added to T_1 in the rotor experiment (t = {t0:.1f} .. {t1:.1f} s)", fontsize=10
        )
    else:
        _empty(a1, "no rotor-coefficient experiment in the log")
    val = ph.get("validation", [])
    if fw is not None and val:
        t0, t1 = val[0]
        w = analysis.window(fw, t0, t1)
        mu = excitation_torque(w)
        axis = int(np.argmax(np.abs(mu).max(axis=0))) if len(w) else 2
        a2.plot(w.t - t0, mu[:, axis], lw=0.6, color="C1")
        a2.set_ylabel(f"mu_1 [N m] ({'xyz'[axis]} torque)")
        a2.set_title(
            f"mu_1: added to the torque demand in the validation (t = {t0:.1f} .. {t1:.1f} s)", fontsize=10
        )
    else:
        _empty(a2, "no validation experiment in the log")
    a2.set_xlabel("time in the experiment [s]")
    fig.suptitle("Fig. 5: random excitation signals delta_1 and mu_1")
    fig.tight_layout()
    _save(fig, path)


def fig6(logs, rep, path, plt):
    val = rep.get("_validation") if rep else None
    if val is None:
        val = analysis.validation(logs, (rep or {}).get("_params"))
    fig, axes = plt.subplots(2, 1, figsize=(8, 6.5), sharey=True)
    titles = ["(a) before identification (nominal k_f, k_tau)", "(b) after identification"]
    # the IMU source compares the collective force (report: validation.compares)
    collective = bool(((rep or {}).get("validation") or {}).get("compares"))
    names = (
        ("commanded sum of f_bar_j", "measured m g a_z", "modelled thrusts' sum", "force along body z [N]")
        if collective
        else ("commanded f_bar_1", "measured f_1", "commanded, through the motor lag", "f_1 [N]")
    )
    for i, ax in enumerate(axes):
        if i < len(val):
            label, t, f_cmd, f_meas, f_pred, e, fit = val[i]
            ax.plot(t - t[0], f_cmd, lw=0.9, color="C0", label=names[0])
            ax.plot(t - t[0], f_meas, lw=0.6, color="C1", alpha=0.85, label=names[1])
            ax.plot(t - t[0], f_pred, lw=0.6, color="k", ls=":", label=names[2])
            ax.set_title(f"{titles[i]}: NE {e:.3f}, fit {fit:.1f} %", fontsize=10)
            ax.set_ylabel(names[3])
            ax.legend(loc="upper right", fontsize=7)
        else:
            ax.set_title(titles[i], fontsize=10)
            _empty(ax, "no validation data in the log")
    axes[-1].set_xlabel("time in the validation [s]")
    fig.suptitle(
        "Fig. 6: measured collective force vs the modelled thrusts' sum"
        if collective
        else "Fig. 6: commanded vs measured thrust of rotor 1"
    )
    fig.tight_layout()
    _save(fig, path)


def fig7(logs, rep, path, plt):
    rates = rep.get("_rates") if rep else None
    if rates is None:
        rates = analysis.rate_comparison(logs, rep.get("_params", {}) if rep else {})
    by_kind = {kind: (t, w, wm, fits) for kind, t, w, wm, fits in rates}
    fig, axes = plt.subplots(3, 1, figsize=(8, 8))
    src = "simulator (truth log)" if logs.truth is not None else "measured (firmware log)"
    for i, (ax, kind, lab) in enumerate(zip(axes, ("ixx", "iyy", "izz"), ("omega_x", "omega_y", "omega_z"))):
        if kind in by_kind:
            t, w, wm, fits = by_kind[kind]
            ax.plot(t - t[0], w[:, i], lw=0.8, label=src)
            ax.plot(t - t[0], wm[:, i], lw=0.8, ls="--", label="analytical model, eqs. (1)-(10)")
            ax.set_title(f"({'abc'[i]}) {lab} during the I_{kind[1]} experiment: fit {fits[i]:.1f} %")
            ax.set_ylabel(f"{lab} [rad/s]")
            ax.legend(loc="upper right", fontsize=8)
        else:
            ax.set_title(f"({'abc'[i]}) {lab}")
            _empty(ax, f"no {kind} experiment in the log")
    axes[-1].set_xlabel("time in the experiment [s]")
    fig.suptitle("Fig. 7: body rates, simulator vs the model with the estimated parameters")
    fig.tight_layout()
    _save(fig, path)


def convergence_series(logs):
    """{key: (t, est, sd)} of the live estimates in the firmware log, over the phase
    that estimates each (kf, ktau and their plain versions; ixx, iyy, izz)."""
    fw = logs.fw
    out = {}
    if fw is None or not fw.has("est"):
        return out
    ph = analysis.phases(logs)
    for key, slot in EST_SLOTS.items():
        for t0, t1 in ph.get(EST_PHASE[key], [])[:1]:
            w = analysis.window(fw, t0, t1)
            ok = (w.est[:, slot] != 0) & np.isfinite(w.est[:, slot]) & np.isfinite(w.est_sd[:, slot])
            if np.any(ok):
                out[key] = (w.t[ok], w.est[ok, slot], w.est_sd[ok, slot])
    return out


def applied_results(logs, rep):
    """{key: (estimate, sd, accepted, reason)} of each quantity's identification result: the
    report's parameter rows (a mission), else the firmware log's OCTO_ID_RESULT records."""
    from . import id_results

    out = {}
    rows = (rep or {}).get("parameters") or {}
    for key, r in rows.items():
        if r.get("estimate") is not None and r.get("sd") is not None:
            out[key] = (float(r["estimate"]), float(r["sd"]), bool(r.get("accepted")), r.get("reason"))
    if out or logs is None or not getattr(logs, "id_results", None):
        return out
    from .quantities import QUANTITIES

    vals, verdicts = id_results.to_params(logs.id_results), id_results.verdicts(logs.id_results)
    for q in QUANTITIES:
        est, sd = vals.get(q.est), vals.get(q.sd)
        if est and sd is not None and np.isfinite(est) and np.isfinite(sd):
            v = verdicts.get(q.key, {})
            out[q.key] = (float(est), float(sd), bool(v.get("accepted")), v.get("reason"))
    return out


# what each live trace is beside the result (the result comes from another estimator, or
# carries more in its sd)
LIVE_LABEL = {
    "kf": "auxiliary: live lag-aware RLS (not the result: the motor model's)",
    "ktau": "auxiliary: live lag-aware RLS (not the result: the motor model's)",
    "ixx": "auxiliary: live RLS (its sd without the gyro scale's share)",
    "iyy": "auxiliary: live RLS (its sd without the gyro scale's share)",
    "izz": "auxiliary: live RLS (its sd without the gyro scale's share)",
}


def convergence(logs, rep, path, plt):
    from .quantities import QUANTITIES

    series = convergence_series(logs)
    applied = applied_results(logs, rep)
    truth = (rep or {}).get("truth", {})
    fig, axes = plt.subplots(len(QUANTITIES), 1, figsize=(8, 11.5))
    for ax, q in zip(axes, QUANTITIES):
        if q.key not in series and q.key not in applied:
            _empty(ax, f"no {q.label} estimate in the log")
            ax.set_ylabel(f"{q.label} [{q.unit}]", fontsize=8)
            continue
        centre, spread = [], []
        if q.key in series:
            t, est, sd = series[q.key]
            ax.plot(t, est, lw=0.8, color="0.45", label=LIVE_LABEL.get(q.key, "auxiliary: live estimate"))
            ax.fill_between(t, est - 2 * sd, est + 2 * sd, color="0.6", alpha=0.2, lw=0)
            tail = slice(len(est) // 3, None)
            centre += list(est[tail])
            spread += list(2 * sd[tail])
            t0, t1 = float(t[0]), float(t[-1])
        if q.key + "_plain" in series:
            tp, ep, _ = series[q.key + "_plain"]
            ax.plot(tp, ep, lw=0.7, color="C3", ls="-.", label="auxiliary: plain LS (eq. 20)")
        if q.key in applied:
            val, sd_a, ok, why = applied[q.key]
            if q.key not in series:  # the phase's window, else the axis's
                t0, t1 = ((rep or {}).get("truth_window_s") or {}).get(q.key) or ax.get_xlim()
            # the result, from the end of the phase whose data it comes from
            te = t1 + 0.15 * max(t1 - t0, 1.0)
            word = "applied" if ok else "not applied" + (f": {why}" if why else "")
            ax.fill_between([t0, te], val - 2 * sd_a, val + 2 * sd_a, color="C0", alpha=0.3, lw=0)
            ax.plot(
                [t0, te],
                [val, val],
                lw=1.6,
                color="C0",
                label=f"identification result {val:.5g}, sd {sd_a:.2g} (band 2 sd; {word})",
            )
            centre.append(val)
            spread.append(2 * sd_a)
        tv = truth.get(q.key)
        if tv is not None:
            ax.axhline(tv, ls="--", color="k", lw=0.8, label="truth")
            dev = [abs(c - tv) + w for c, w in zip(centre, spread)]
            span = max([abs(tv) * 0.01] + [1.2 * x for x in dev])
            if q.key + "_plain" in series:
                span = max(span, 1.2 * abs(float(series[q.key + "_plain"][1][-1]) - tv))
            ax.set_ylim(tv - span, tv + span)
        ax.legend(loc="upper right", fontsize=6)
        ax.set_ylabel(f"{q.label} [{q.unit}]", fontsize=8)
    axes[-1].set_xlabel("simulated time [s]")
    fig.suptitle(
        "Identification results (+/- 2 sd, as applied) and the live estimates in flight; truth dashed",
        fontsize=10,
    )
    fig.tight_layout()
    _save(fig, path)


def make_figures(logs, rep, outdir):
    """Writes the four figures into outdir; returns their file names."""
    plt = _plt()
    done = []
    for name, fn in (
        ("fig5_excitation.png", lambda p: fig5(logs, p, plt)),
        ("fig6_validation.png", lambda p: fig6(logs, rep, p, plt)),
        ("fig7_rates.png", lambda p: fig7(logs, rep, p, plt)),
        ("convergence.png", lambda p: convergence(logs, rep, p, plt)),
    ):
        fn(os.path.join(outdir, name))
        plt.close("all")
        done.append(name)
    return done
