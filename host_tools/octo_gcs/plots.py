"""The report's figures (matplotlib, Agg backend), after the paper's Figures 5, 6, 7.

- fig5_excitation.png: delta_1 (added to rotor 1's throttle, rotor experiment) and
  mu_1 (added to the demanded torque, validation), over time.
- fig6_validation.png: commanded f_bar_1 vs measured f_1, (a) before and (b) after
  identification.
- fig7_rates.png: body rates of the simulator vs the analytical model (eqs. 1-10,
  RK4, estimated parameters, same throttles) during the inertia experiments.
- convergence.png: the live estimates +/- 2 sigma over simulated time, truth dashed.

Every figure is written atomically (temporary name, then rename). A figure whose
data is missing from the logs says so inside the figure instead of failing.
"""

import os
import tempfile

import numpy as np

from . import analysis

FIGURES = ("fig5_excitation.png", "fig6_validation.png", "fig7_rates.png", "convergence.png")

# est[] slots in OCTO_FW_FRAME while each experiment runs: (slot, key, label)
# (firmware/app/experiment.h documents the order; mapped by the experiment's name
# in the events when the slot order differs between experiments)
EST_SLOTS = {
    "rotor": [(0, "kf", "k_f [N]"), (1, "ktau", "k_tau [N m]")],
    "ixx": [(0, "ixx", "I_x [kg m^2]")],
    "iyy": [(0, "iyy", "I_y [kg m^2]")],
    "izz": [(0, "izz", "I_z [kg m^2]")],
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
        from .report import file_mode
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


def _mu_field(fw):
    for name in ("mu", "mu_1", "mu1", "tau_exc", "tau_delta"):
        if fw.has(name):
            return name
    return None


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
        a1.set_title(f"delta_1: added to T_1 during the rotor experiment (from t = {t0:.1f} s)")
    else:
        _empty(a1, "no rotor-coefficient experiment in the log")
    val = ph.get("validation", [])
    if fw is not None and val:
        t0, t1 = val[0]
        w = analysis.window(fw, t0, t1)
        name = _mu_field(fw)
        if name is not None:
            mu = np.asarray(getattr(w, name))
            mu = mu[:, 0] if mu.ndim == 2 else mu
            a2.plot(w.t - t0, mu, lw=0.6, color="C1")
            a2.set_ylabel("mu_1 [N m]")
        else:
            a2.plot(w.t - t0, w.tau_dem[:, 0], lw=0.6, color="C1")
            a2.set_ylabel("tau_x demand [N m]\n(includes mu_1)")
        a2.set_title(f"mu_1: added to the torque demand during validation (from t = {t0:.1f} s)")
    else:
        _empty(a2, "no validation experiment in the log")
    a2.set_xlabel("time in the experiment [s]")
    fig.suptitle("Fig. 5: random excitation signals delta_1 and mu_1")
    fig.tight_layout()
    _save(fig, path)


def fig6(logs, rep, path, plt):
    val = rep.get("_validation") if rep else None
    if val is None:
        val = analysis.validation(logs)
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharey=True)
    titles = ["(a) before identification (nominal k_f, k_tau)", "(b) after identification (estimates)"]
    for i, ax in enumerate(axes):
        if i < len(val):
            label, t, f_cmd, f_meas, e, fit = val[i]
            ax.plot(t - t[0], f_cmd, lw=0.8, label="commanded f_bar_1")
            ax.plot(t - t[0], f_meas, lw=0.6, alpha=0.8, label="measured f_1")
            ax.set_title(f"{titles[i]}: NE {e:.3f}, fit {fit:.1f} %")
            ax.set_ylabel("f_1 [N]")
            ax.legend(loc="upper right", fontsize=8)
        else:
            ax.set_title(titles[i])
            _empty(ax, "no validation data in the log")
    axes[-1].set_xlabel("time in the validation [s]")
    fig.suptitle("Fig. 6: commanded vs measured thrust of rotor 1")
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
    """{key: (t, est, sd)} of the live estimates in the firmware log."""
    fw = logs.fw
    out = {}
    if fw is None or not fw.has("est"):
        return out
    for kind, wins in analysis.phases(logs).items():
        for slot, key, _label in EST_SLOTS.get(kind, []):
            for t0, t1 in wins[:1]:
                w = analysis.window(fw, t0, t1)
                ok = (w.est[:, slot] != 0) & np.isfinite(w.est[:, slot])
                if np.any(ok):
                    out[key] = (w.t[ok], w.est[ok, slot], w.est_sd[ok, slot])
    return out


def convergence(logs, rep, path, plt):
    from .identify import QUANTITIES
    series = convergence_series(logs)
    truth = (rep or {}).get("truth", {})
    fig, axes = plt.subplots(len(QUANTITIES), 1, figsize=(8, 10))
    for ax, q in zip(axes, QUANTITIES):
        if q.key in series:
            t, est, sd = series[q.key]
            ax.plot(t, est, lw=0.9, color="C0", label="estimate")
            ax.fill_between(t, est - 2 * sd, est + 2 * sd, color="C0", alpha=0.25, lw=0, label="+/- 2 sigma")
            tv = truth.get(q.key)
            if tv is not None:
                ax.axhline(tv, ls="--", color="k", lw=0.8, label="truth")
                span = max(abs(tv) * 0.05, float(np.nanmax(np.abs(est[len(est) // 3:] - tv))) * 1.5
                           if len(est) > 3 else abs(tv) * 0.05)
                ax.set_ylim(tv - span, tv + span)
            ax.legend(loc="upper right", fontsize=7)
        else:
            _empty(ax, f"no {q.label} estimate in the log")
        ax.set_ylabel(f"{q.label} [{q.unit}]", fontsize=8)
    axes[-1].set_xlabel("simulated time [s]")
    fig.suptitle("Convergence of the recursive estimates (+/- 2 sigma); truth dashed")
    fig.tight_layout()
    _save(fig, path)


def make_figures(logs, rep, outdir):
    """Writes the four figures into outdir; returns their file names."""
    plt = _plt()
    done = []
    for name, fn in (("fig5_excitation.png", lambda p: fig5(logs, p, plt)),
                     ("fig6_validation.png", lambda p: fig6(logs, rep, p, plt)),
                     ("fig7_rates.png", lambda p: fig7(logs, rep, p, plt)),
                     ("convergence.png", lambda p: convergence(logs, rep, p, plt))):
        fn(os.path.join(outdir, name))
        plt.close("all")
        done.append(name)
    return done
