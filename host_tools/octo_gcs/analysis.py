"""What the report and the figures compute from the logs.

- Phases of the identification (from the firmware's "ID k/n: name" events).
- Validation (Fig. 6): commanded rotor-1 thrust f_bar_1 (the allocation) against the
  measured f_1 (X-Plane's row 35), normalised error and fit; under the IMU source the
  measured collective force m g a_z against the modelled thrusts' sum.
- Fig. 7: the body rates of the simulator against the paper's analytical model,
  eqs. (1)-(10) integrated with RK4 (model.py) from the same throttle inputs with the
  ESTIMATED parameters, over each inertia experiment.

Fit % = 100 (1 - ||y - y_hat|| / ||y - mean(y)||); NE = RMS(y - y_hat) / RMS(y).
"""

import math
import re

import numpy as np

from .model import Model, Params

FRAME_DT = 1.0 / 90.0
RK4_STEP = 0.002  # the paper's T

# the firmware's defaults for the actuator model its estimators use (experiment.c)
DEFAULT_MOT_TAU = 0.03
DEFAULT_DELAY_FR = 0


def actuator_model(params):
    """(motor lag time constant s, transport delay frames) from ID_MOT_TAU, ID_DELAY_FR."""
    tau = params.get("ID_MOT_TAU")
    delay = params.get("ID_DELAY_FR")
    tau = float(tau) if tau is not None and math.isfinite(tau) and tau >= 0 else DEFAULT_MOT_TAU
    delay = (
        int(round(delay)) if delay is not None and math.isfinite(delay) and delay >= 0 else DEFAULT_DELAY_FR
    )
    return tau, delay


def fit_pct(y, yhat):
    y, yhat = np.asarray(y, float), np.asarray(yhat, float)
    den = np.linalg.norm(y - y.mean())
    if len(y) < 2 or den == 0:
        return float("nan")
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / den))


def ne(y, yhat):
    y, yhat = np.asarray(y, float), np.asarray(yhat, float)
    den = math.sqrt(float(np.mean(y**2))) if len(y) else 0.0
    if den == 0:
        return float("nan")
    return float(math.sqrt(float(np.mean((y - yhat) ** 2))) / den)


# ---------------------------------------------------------------- phases
def classify(name):
    """'validation' | 'rotor' | 'ixx' | 'iyy' | 'izz' | None for a phase name."""
    n = name.lower()
    if "valid" in n:
        return "validation"
    m = (
        re.search(r"\bi[_ ]?(x|y|z)\1?\b", n)
        or re.search(r"\b(x|y|z)[- ]axis\b", n)
        or re.search(r"\b(roll|pitch|yaw)\b", n)
    )
    if m:
        axis = {"roll": "x", "pitch": "y", "yaw": "z"}.get(m.group(1), m.group(1))
        return "i" + axis * 2
    if "inertia" in n:
        return None
    if any(w in n for w in ("rotor", "k_f", "kf", "thrust", "coefficient")):
        return "rotor"
    return None


def phases(logs):
    """{'validation': [(t0, t1), ...], 'rotor': [...], 'ixx': [...], ...} from the events."""
    out = {}
    for name, t0, t1, _k in logs.phases():
        kind = classify(name)
        if kind:
            out.setdefault(kind, []).append((t0, t1))
    return out


def window(series, t0, t1, stepped=True):
    m = (series.t >= t0) & (series.t < t1)
    if stepped and series.has("stepped"):
        m &= series.stepped.astype(bool)
    return series.select(m)


# ---------------------------------------------------------------- validation (Fig. 6)
def predicted_thrust(f_cmd, dt, tau, delay):
    """The firmware's validation model of rotor 1's thrust: the allocation behind the
    throttle sent on the previous frame, through `delay` frames and a first-order lag
    (alpha = 1 - exp(-dt / tau), as firmware/core/filt.c)."""
    f_cmd = np.asarray(f_cmd, float)
    x = np.concatenate([f_cmd[:1], f_cmd[:-1]])
    if delay > 0:
        x = np.concatenate([np.repeat(x[:1], delay), x[:-delay]])
    if tau <= 0:
        return x
    a = 1.0 - math.exp(-dt / tau)
    y = np.empty_like(x)
    acc = x[0]
    for i, v in enumerate(x.tolist()):
        acc += a * (v - acc)
        y[i] = acc
    return y


def validation(logs, params=None, settle_s=1.0):
    """[(label, t, f_cmd, f_meas, f_pred, ne, fit)] for the validation windows (before,
    after): commanded f_bar_1 (the allocation), measured f_1 (row 35) and the command
    through the motor model; NE and fit of measured vs predicted after `settle_s` of
    the phase (the firmware's excitation starts after 1 s of settling)."""
    out = []
    fw = logs.fw
    if fw is None:
        return out
    tau, delay = actuator_model(params or {})
    wins = phases(logs).get("validation", [])
    labels = ["before identification", "after identification"] + [
        f"validation {i + 3}" for i in range(max(0, len(wins) - 2))
    ]
    for label, (t0, t1) in zip(labels, wins):
        w = window(fw, t0, t1)
        if len(w) < 10:
            continue
        f_cmd, f_meas = w.rotor_f[:, 0], w.rotor_thrust[:, 0]
        f_pred = predicted_thrust(f_cmd, FRAME_DT, tau, delay)
        m = w.t >= t0 + settle_s
        out.append(
            (label, w.t, f_cmd, f_meas, f_pred, ne(f_meas[m], f_pred[m]), fit_pct(f_meas[m], f_pred[m]))
        )
    return out


def _curve(y, c):
    """The thrust curve g(y) = (1 - c) y + c y^2 (firmware/core/thrmap.h)."""
    return (1.0 - c) * y + c * y * y


def validation_collective(logs, params=None, before=None, settle_s=1.0):
    """The validation under the IMU source, as validation() returns it: the commanded total
    (the allocation's sum), the measured collective force m g a_z along body z (row 4) and the
    modelled thrusts' sum: each rotor's throttle sent on the previous frame through the
    transport delay and lag, the thrust curve and its effectiveness, times the k_f in use at
    the frame. The window before identification is modelled with `before` (the parameters
    before the flight) where it has them, the rest with `params`."""
    out = []
    fw = logs.fw
    if fw is None or not fw.has("accel_b"):
        return out
    wins = phases(logs).get("validation", [])
    labels = ["before identification", "after identification"] + [
        f"validation {i + 3}" for i in range(max(0, len(wins) - 2))
    ]
    for i, (label, (t0, t1)) in enumerate(zip(labels, wins)):
        w = window(fw, t0, t1)
        if len(w) < 10:
            continue
        p = dict(params or {})
        if i == 0 and before:
            p.update({k: v for k, v in before.items() if k in ("ID_MOT_TAU", "ID_DELAY_FR", "MOT_CURVE")})
        tau, delay = actuator_model(p)
        c = p.get("MOT_CURVE", 0.0)
        c = float(c) if c is not None and math.isfinite(c) else 0.0
        g = float(p.get("VEH_GRAV", 9.81))
        f_pred = np.zeros(len(w))
        for j in range(w.throttle.shape[1]):
            s_j = p.get(f"MOT_SCALE{j + 1}", 1.0)
            y = predicted_thrust(w.throttle[:, j], FRAME_DT, tau, delay)
            f_pred += float(s_j) * _curve(y, c)
        f_pred *= w.kf
        f_cmd = w.rotor_f.sum(axis=1)
        f_meas = w.mass * g * w.accel_b[:, 2]
        m = w.t >= t0 + settle_s
        out.append(
            (label, w.t, f_cmd, f_meas, f_pred, ne(f_meas[m], f_pred[m]), fit_pct(f_meas[m], f_pred[m]))
        )
    return out


# ---------------------------------------------------------------- rates vs model (Fig. 7)
def model_params(params):
    """model.Params from vehicle parameters (identified ones where present)."""

    def get(name, default):
        v = params.get(name)
        return float(v) if v is not None and math.isfinite(v) and v > 0 else default

    p = Params()
    inertia = (
        get("ID_IXX_EST", get("VEH_IXX", p.inertia[0])),
        get("ID_IYY_EST", get("VEH_IYY", p.inertia[1])),
        get("ID_IZZ_EST", get("VEH_IZZ", p.inertia[2])),
    )
    ktau = get("ID_KTAU_EST", get("VEH_KTAU", p.ktau))
    ratio = get("ID_KTIZ", 0.0)
    if ratio > 0 and get("ID_KTAU_EST", 0.0) == 0 and get("ID_IZZ_EST", 0.0) == 0:
        # the gyro's k_tau / I_z without either alone: the yaw model needs only the ratio
        ktau = ratio * inertia[2]
    return Params(
        mass=get("VEH_MASS", p.mass),
        g=get("VEH_GRAV", p.g),
        arm_length=get("VEH_ARM_L", p.arm_length),
        kf=get("ID_KF_EST", get("VEH_KF", p.kf)),
        ktau=ktau,
        inertia=inertia,
    )


def simulate_rates(t, q0, w0, throttles, s0, p, motor_tau=0.0, delay_frames=0):
    """The model's body rates through a throttle sequence (row k acts from t[k] to
    t[k+1]), with the model's actuator: a transport delay of `delay_frames` frames
    and a first-order lag `motor_tau` from s0; thrust f_j = k_f s_j, wrench by
    Gamma_o (eq. 11, 14), rates by eqs. (7)-(9) with RK4 in steps of at most 2 ms
    (the paper's T). The rates do not depend on q0 (kept for the caller's symmetry).
    Returns the rates at t (n x 3)."""
    m = Model(p)
    thr = np.asarray(throttles, float)
    if delay_frames > 0:
        thr = np.vstack([np.repeat(thr[:1], delay_frames, axis=0), thr[:-delay_frames]])
    if len(t) < 2:
        return np.asarray(w0, float).reshape(1, 3)
    # The torque is linear in the rotor speeds: with G = Gamma_o's torque rows times k_f, the
    # torque at sub-step j of frame k is P_k + c_j E_k, P_k = G thr_k the commanded torque and
    # E_k = G s_k - P_k the lag's remainder (c_j = a^(j + 1/2), a the lag over one sub-step);
    # G s_(k+1) = P_k + E_k a^n. So the whole integration runs on 3-vectors of floats, one
    # pass, without arrays per frame.
    G = m.gamma[1:4] * p.kf
    P = (G @ thr[: len(t) - 1].T).T.tolist()
    qx, qy, qz = (G @ np.asarray(s0, float)).tolist()
    Ix, Iy, Iz = (float(v) for v in m.I)
    ax_, ay_, az_ = (Iy - Iz) / Ix, (Iz - Ix) / Iy, (Ix - Iy) / Iz
    wx, wy, wz = (float(v) for v in w0)
    out = [(wx, wy, wz)]
    tl = np.asarray(t, float).tolist()
    for k in range(len(tl) - 1):
        dt = tl[k + 1] - tl[k]
        n = max(1, int(math.ceil(dt / RK4_STEP - 1e-9)))
        h = dt / n
        a = math.exp(-h / motor_tau) if motor_tau > 0 else 0.0
        px, py, pz = P[k]
        ex, ey, ez = qx - px, qy - py, qz - pz
        c = math.sqrt(a)
        h2, h6 = 0.5 * h, h / 6.0
        for _ in range(n):
            bx, by, bz = (px + c * ex) / Ix, (py + c * ey) / Iy, (pz + c * ez) / Iz
            c *= a
            k1x, k1y, k1z = ax_ * wy * wz + bx, ay_ * wx * wz + by, az_ * wx * wy + bz
            x, y, z = wx + h2 * k1x, wy + h2 * k1y, wz + h2 * k1z
            k2x, k2y, k2z = ax_ * y * z + bx, ay_ * x * z + by, az_ * x * y + bz
            x, y, z = wx + h2 * k2x, wy + h2 * k2y, wz + h2 * k2z
            k3x, k3y, k3z = ax_ * y * z + bx, ay_ * x * z + by, az_ * x * y + bz
            x, y, z = wx + h * k3x, wy + h * k3y, wz + h * k3z
            k4x, k4y, k4z = ax_ * y * z + bx, ay_ * x * z + by, az_ * x * y + bz
            wx += h6 * (k1x + 2 * k2x + 2 * k3x + k4x)
            wy += h6 * (k1y + 2 * k2y + 2 * k3y + k4y)
            wz += h6 * (k1z + 2 * k2z + 2 * k3z + k4z)
        an = a**n
        qx, qy, qz = px + ex * an, py + ey * an, pz + ez * an
        out.append((wx, wy, wz))
    return np.array(out)


def rate_comparison(logs, params):
    """[(axis kind, t, rates_sim (n x 3), rates_model (n x 3), fit per axis [3])] over
    each inertia experiment, with the estimated parameters in `params`."""
    p = model_params(params)
    tau, delay = actuator_model(params)
    ph = phases(logs)
    out = []
    for kind in ("ixx", "iyy", "izz"):
        for t0, t1 in ph.get(kind, [])[:1]:
            if logs.truth is not None:
                tr = window(logs.truth, t0, t1, stepped=False)
                if len(tr) < 10:
                    continue
                # record k carries the command that drove the plant from t[k-1] to t[k]
                t, w, q = tr.t, tr.rate_b, tr.q_i2b
                thr = np.vstack([tr.throttle_cmd[1:], tr.throttle_cmd[-1:]])
                s0 = tr.s[0]
                wm = simulate_rates(t, q[0], w[0], thr, s0, p, tau, 0)
            else:
                fw = window(logs.fw, t0, t1)
                if len(fw) < 10:
                    continue
                t, w, q = fw.t, fw.rate_b, fw.q
                wm = simulate_rates(t, q[0], w[0], fw.throttle, fw.throttle[0], p, tau, delay)
            fits = [fit_pct(w[:, i], wm[:, i]) for i in range(3)]
            out.append((kind, t, w, wm, fits))
    return out
