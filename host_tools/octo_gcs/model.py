"""The paper's analytical octocopter model, eqs. (1)-(10), integrated with RK4.

Frames as in the paper: S_I inertial with Z up (gravity [0, 0, -g]); S_B body with
X forward, Y left, Z up; q = [q1, q2, q3, q4] = [w, x, y, z] rotates body vectors into
S_I (eq. 1-4 with omega in the body frame). Rotor j (1-based) sits at angle
-(j - 1) * 45 deg from X_B at arm length l, so that Gamma_o (eq. 14) holds as written.

This is the ground station's independent model: Figure 7 compares it with the simulator
from the same inputs, and the tests check it against octo-sim in ideal mode.
"""

from dataclasses import dataclass, field

import numpy as np

S2 = np.sqrt(2.0) / 2.0


@dataclass
class Params:
    mass: float = 2.132
    g: float = 9.796
    arm_length: float = 0.35
    kf: float = 28.0269
    ktau: float = 0.3869
    inertia: tuple = (0.0628, 0.0762, 0.1014)


def gamma_o(l, k):
    """Gamma_o of eq. (14): [f, tau_x, tau_y, tau_z] = Gamma_o @ [f_1 .. f_8], k = k_tau / k_f."""
    s = S2 * l
    return np.array(
        [
            [1, 1, 1, 1, 1, 1, 1, 1],
            [0, -s, -l, -s, 0, s, l, s],
            [-l, -s, 0, s, l, s, 0, -s],
            [k, -k, k, -k, k, -k, k, -k],
        ],
        dtype=float,
    )


def quat_to_rot(q):
    """Rotation matrix of q = [w, x, y, z] (body to inertial)."""
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def omega_matrix(w):
    """Omega of eq. (2)/(4)."""
    wx, wy, wz = w
    return 0.5 * np.array(
        [
            [0, -wx, -wy, -wz],
            [wx, 0, wz, -wy],
            [wy, -wz, 0, wx],
            [wz, wy, -wx, 0],
        ]
    )


@dataclass
class State:
    r: np.ndarray = field(default_factory=lambda: np.zeros(3))
    v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    q: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    w: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def vector(self):
        return np.concatenate([self.r, self.v, self.q, self.w])

    @staticmethod
    def of(x):
        return State(x[0:3].copy(), x[3:6].copy(), x[6:10].copy(), x[10:13].copy())


class Model:
    """x_dot = F(x, u) of eqs. (1)-(10); u = [f, tau_x, tau_y, tau_z]."""

    def __init__(self, p: Params):
        self.p = p
        self.I = np.array(p.inertia, dtype=float)
        self.gamma = gamma_o(p.arm_length, p.ktau / p.kf)

    def wrench_of_rotor_thrusts(self, f_rotors):
        return self.gamma @ np.asarray(f_rotors, dtype=float)

    def wrench_of_throttles(self, throttles):
        """Eq. (16)-(17) then eq. (11): the model's idea of what throttles produce."""
        return self.wrench_of_rotor_thrusts(self.p.kf * np.asarray(throttles, dtype=float))

    def deriv(self, x, u):
        p, I = self.p, self.I
        q, w = x[6:10], x[10:13]
        f, tau = u[0], u[1:4]
        n = quat_to_rot(q)[:, 2]  # rotor-plane normal in S_I
        acc = f / p.mass * n + np.array([0.0, 0.0, -p.g])  # eq. (10)
        qd = omega_matrix(w) @ q  # eq. (1)-(4)
        wd = np.array(
            [  # eqs. (7)-(9)
                ((I[1] - I[2]) * w[1] * w[2] + tau[0]) / I[0],
                ((I[2] - I[0]) * w[0] * w[2] + tau[1]) / I[1],
                ((I[0] - I[1]) * w[0] * w[1] + tau[2]) / I[2],
            ]
        )
        return np.concatenate([x[3:6], acc, qd, wd])

    def step(self, x, u, dt):
        """One RK4 step with u held constant; the quaternion is renormalised after."""
        k1 = self.deriv(x, u)
        k2 = self.deriv(x + 0.5 * dt * k1, u)
        k3 = self.deriv(x + 0.5 * dt * k2, u)
        k4 = self.deriv(x + dt * k3, u)
        y = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        y[6:10] /= np.linalg.norm(y[6:10])
        return y

    def simulate(self, x0, inputs, dt, substeps=1):
        """Integrate from x0 through a sequence of wrenches u_k, each held for dt
        (split into `substeps` RK4 steps). Returns the states, len(inputs) + 1 rows."""
        x = np.asarray(x0, dtype=float).copy()
        out = [x.copy()]
        h = dt / substeps
        for u in inputs:
            for _ in range(substeps):
                x = self.step(x, np.asarray(u, dtype=float), h)
            out.append(x.copy())
        return np.array(out)
