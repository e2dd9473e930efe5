"""octo-gcs's analytical model (model.py, eqs. 1-10 with RK4) against octo-sim in
ideal mode (no noise, lag or delay): the same throttle sequence, sent through
X-Plane's protocol in lockstep, must give the same body rates, attitude and
position, both in octo-sim's ground truth and in its X-Plane Data Output rows
(which checks the frame conventions the ground station assumes)."""

import math
import sys

import numpy as np
import pytest

import xplane_proto as xp
from conftest import BUILD
from test_sim_support import SimUnderTest

sys.path.insert(0, str(BUILD / "gen" / "python"))

from octo_gcs.analysis import simulate_rates  # noqa: E402
from octo_gcs.logs import Logs  # noqa: E402
from octo_gcs.model import Model, Params, State, quat_to_rot  # noqa: E402

RATE = 90.0
N_FRAMES = 270   # 3 s


def throttle_sequence(p, n):
    """Lift-off with 1.3 m g, then steps and sines on every axis (all 8 rotors move)."""
    T0 = 1.3 * p.mass * p.g / (8 * p.kf)
    out = []
    for k in range(n):
        t = k / RATE
        d = np.zeros(8)
        d[[1, 2, 3]] += 0.0015 * math.sin(2 * math.pi * 1.3 * t)       # roll
        d[[5, 6, 7]] -= 0.0015 * math.sin(2 * math.pi * 1.3 * t)
        sq = 1 if (k // 20) % 2 else -1                                   # pitch steps
        d[[7, 0, 1]] += 0.0015 * sq
        d[[3, 4, 5]] -= 0.0015 * sq
        d[0::2] += 0.006 * math.sin(2 * math.pi * 0.7 * t)             # yaw
        d[1::2] -= 0.006 * math.sin(2 * math.pi * 0.7 * t)
        out.append(np.clip(T0 + d, 0.0, 1.0))
    return np.array(out, dtype=np.float32).astype(float)   # DATA row 25 carries float32


def euler_xplane(q):
    """X-Plane's roll, pitch, heading (deg) of the paper's q (FLU body -> NWU inertial)."""
    D = np.diag([1.0, -1.0, -1.0])
    R = D @ quat_to_rot(q) @ D                         # FRD body -> NED
    roll = math.degrees(math.atan2(R[2, 1], R[2, 2]))
    pitch = math.degrees(-math.asin(max(-1.0, min(1.0, R[2, 0]))))
    heading = math.degrees(math.atan2(R[1, 0], R[0, 0])) % 360.0
    return roll, pitch, heading


@pytest.mark.parametrize("version", [11, 12])
def test_model_matches_octo_sim_ideal(launch, port, tmp_path, version):
    p = Params()
    log = tmp_path / "truth.lcm"
    sim = SimUnderTest(launch, port, "--ideal", "--lockstep", "--xplane-version", version,
                       "--lcm", f"file://{log}", rows=[1, 16, 17, 20, 21])
    thr = throttle_sequence(p, N_FRAMES)
    frames = [sim.start_lockstep(thr[0])]
    for k in range(1, N_FRAMES):
        frames.append(sim.step(thr[k]))
    sim.stop()

    # the model from rest at the origin, each throttle row held for one frame
    m = Model(p)
    x = State().vector()
    states = [x]
    for k in range(N_FRAMES):
        t0, t1 = k / RATE, (k + 1) / RATE
        # octo-sim's steps: full 2 ms steps, the last one shortened
        edges = list(np.arange(t0, t1 - 1e-12, 0.002)) + [t1]
        u = m.wrench_of_throttles(thr[k])
        for a, b in zip(edges, edges[1:]):
            x = m.step(x, u, b - a)
        states.append(x)
    states = np.array(states)

    # 1. ground truth, frame by frame
    truth = Logs([log]).truth
    n = min(len(truth), N_FRAMES + 1)
    assert n == N_FRAMES + 1, f"truth log has {len(truth)} records"
    assert np.allclose(truth.t[:n], np.arange(n) / RATE, atol=1e-9)
    assert truth.pos_i[-1, 2] > 0.3, "the vehicle should have lifted off"
    w_err = np.abs(truth.rate_b[:n] - states[:n, 10:13]).max()
    q_err = np.abs(truth.q_i2b[:n] - states[:n, 6:10]).max()
    r_err = np.abs(truth.pos_i[:n] - states[:n, 0:3]).max()
    w_span = np.abs(states[:, 10:13]).max(axis=0)
    print(f"model vs truth: rates {w_err:.2e} rad/s (span {w_span}), q {q_err:.2e}, pos {r_err:.2e} m")
    assert min(w_span) > 0.05, "every axis should rotate"
    assert w_err < 1e-9 and q_err < 1e-9 and r_err < 1e-8
    # the thrust the model assigns to the throttles
    assert np.allclose(truth.thrust[1:n], p.kf * thr[:n - 1], rtol=1e-9)

    # 2. X-Plane Data Output (float32, degrees, FRD/NED conventions)
    for k, f in enumerate(frames):
        assert f[1][2] == pytest.approx((k + 1) / RATE, abs=1e-4), "DATA frames out of step"
        s = states[k + 1]
        P, Q, R = xp.row16_pqr(f[16], version)
        wx, wy, wz = s[10:13]
        assert (P, Q, R) == pytest.approx((wx, -wy, -wz), abs=2e-5), k
        pitch, roll, heading = f[17][:3]
        er, ep, eh = euler_xplane(s[6:10])
        assert roll == pytest.approx(er, abs=2e-3) and pitch == pytest.approx(ep, abs=2e-3), k
        dh = (heading - eh + 180.0) % 360.0 - 180.0
        assert abs(dh) < 2e-3, k
        north, east, down = xp.ned_from_opengl(*f[21][:3])
        # OpenGL's origin is at sea level, below the take-off point (the field is 640 m MSL)
        assert (north, -east, -down - 640.0) == pytest.approx(tuple(s[0:3]), abs=2e-3), k


def test_rate_model_helper_matches_truth_log_inputs(launch, port, tmp_path):
    """analysis.simulate_rates (what Fig. 7 uses) from a truth log's own throttles."""
    p = Params()
    log = tmp_path / "truth.lcm"
    sim = SimUnderTest(launch, port, "--ideal", "--lockstep", "--lcm", f"file://{log}", rows=[16])
    thr = throttle_sequence(p, 180)
    sim.start_lockstep(thr[0])
    for k in range(1, 180):
        sim.step(thr[k])
    sim.stop()
    tr = Logs([log]).truth
    t = tr.t[:181]
    cmd = np.vstack([tr.throttle_cmd[1:181], tr.throttle_cmd[180:181]])
    w = simulate_rates(t, tr.q_i2b[0], tr.rate_b[0], cmd, tr.s[0], p)
    assert np.abs(w - tr.rate_b[:181]).max() < 1e-5


def test_rates_integrator_equals_the_full_model():
    """analysis.simulate_rates (eqs. 7-9 alone, used for Fig. 7) gives the full model's rates."""
    p = Params(inertia=(0.05, 0.09, 0.12))
    m = Model(p)
    rng = np.random.default_rng(2)
    thr = 0.1 + rng.normal(0, 0.004, (300, 8))
    x0 = State(w=np.array([0.3, -0.2, 0.5])).vector()
    xs = m.simulate(x0, [m.wrench_of_throttles(u) for u in thr], 1 / 90, substeps=6)
    w = simulate_rates(np.arange(301) / 90, x0[6:10], x0[10:13], thr, thr[0], p)
    assert np.abs(xs[:, 10:13] - w).max() < 1e-12
