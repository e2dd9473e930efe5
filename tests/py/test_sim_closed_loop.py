"""A client that knows only X-Plane's protocol flies octo-sim: a plain PD hover
controller over DATA rows 16/17/21 and DATA row 25 (or DREFs), mixing through
Gamma_o's pseudo-inverse. Holding a hover proves the signs end to end."""

import math

import numpy as np
import pytest

import xplane_proto as xp
from test_sim_support import HOVER, KF, KTAU, SimUnderTest

M, G, L = 2.132, 9.796, 0.35
I = (0.0628, 0.0762, 0.1014)
R2 = math.sqrt(2) / 2 * L
K = KTAU / KF
GAMMA = np.array([
    [1, 1, 1, 1, 1, 1, 1, 1],
    [0, -R2, -L, -R2, 0, R2, L, R2],
    [-L, -R2, 0, R2, L, R2, 0, -R2],
    [K, -K, K, -K, K, -K, K, -K],
])
MIX = np.linalg.pinv(GAMMA)


FIELD_MSL = 640.0   # octo-sim's default field elevation: OpenGL's origin is at sea level


def control(f, target_alt=1.0):
    pitch, roll, heading = (math.radians(v) for v in f[17][:3])
    P, Q, R = xp.row16_pqr(f[16], 12)
    yaw_err = math.atan2(math.sin(heading), math.cos(heading))
    alt, vz = f[21][1] - FIELD_MSL, f[21][4]
    wn, z = 6.0, 0.7
    # torques in the paper's body frame (X fwd, Y left, Z up): w = (P, -Q, -R)
    tx = I[0] * (-wn * wn * roll - 2 * z * wn * P)
    ty = I[1] * (wn * wn * pitch + 2 * z * wn * Q)
    tz = I[2] * (9.0 * yaw_err + 2 * z * 3.0 * R)
    thrust = M * (G + 4.0 * (target_alt - alt) - 2.8 * vz) / max(0.5, math.cos(roll) * math.cos(pitch))
    return list(np.clip(MIX @ np.array([thrust, tx, ty, tz]) / KF, 0.0, 1.0))


@pytest.mark.parametrize("via", ["row25", "dref"])
def test_pd_client_hovers_at_1m(launch, port, via):
    s = SimUnderTest(launch, port, "--lockstep", "--seed", "3", "--rows", "1,16,17,21")
    if via == "dref":
        s.send(xp.encode_dref(xp.OVERRIDE_THROTTLES, 1.0))
    f = s.next_data()
    s.link.drain()
    worst, t = 0.0, 0.0
    for n in range(900):                                      # 10 s
        u = control(f)
        if via == "row25":
            s.command(u)
        else:
            for d in xp.throttle_drefs(u):
                s.send(d)
        f = s.next_data()
        while f[1][2] == 0.0:
            f = s.next_data()
        t = f[1][2]
        if t > 5.0:
            worst = max(worst, abs(f[21][1] - FIELD_MSL - 1.0), 0.01 * abs(f[17][1]), 0.01 * abs(f[17][0]))
    assert t == pytest.approx(10.0, abs=1e-4)
    assert worst < 0.05, worst                               # within 5 cm (and 5 deg) after 5 s
    assert abs(f[21][0]) < 2.0 and abs(f[21][2]) < 2.0
