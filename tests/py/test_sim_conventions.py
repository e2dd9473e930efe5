"""Sign conventions of Gamma_o (eq. 14) seen through X-Plane's frames, and the
units of the Data Output rows, on the live simulator (lockstep, --ideal)."""

import math

import pytest

import xplane_proto as xp
from test_sim_support import HOVER, KF, KTAU, SimUnderTest, f32

ROWS = "1,4,16,17,20,21,25,26,35,36"


def fly(launch, port, throttles, frames=45, *extra):
    """Lift off with `throttles` (rotor 1..8) for `frames` lockstep frames; returns
    the last DATA frame."""
    s = SimUnderTest(launch, port, "--lockstep", "--ideal", "--rows", ROWS, *extra)
    f = s.start_lockstep(throttles)
    for _ in range(frames):
        f = s.step(throttles)
    s.stop()
    return f


def raised(rotors, base=HOVER * 1.2, delta=0.01):
    return [base + (delta if j + 1 in rotors else 0.0) for j in range(8)]



def test_raising_right_rotors_rolls_left(launch, port):
    f = fly(launch, port, raised({2, 3, 4}))
    pitch, roll, heading = f[17][0], f[17][1], f[17][2]
    p, q, r = xp.row16_pqr(f[16], 12)
    assert roll < -1.0 and p < 0                              # left wing down
    assert abs(pitch) < 0.05 * abs(roll)
    assert f[21][1] > 0                                       # it did lift off


def test_raising_front_rotors_pitches_nose_up(launch, port):
    f = fly(launch, port, raised({8, 1, 2}))
    pitch, roll = f[17][0], f[17][1]
    p, q, r = xp.row16_pqr(f[16], 12)
    assert pitch > 1.0 and q > 0
    assert abs(roll) < 0.05 * pitch


def test_raising_odd_rotors_yaws_left(launch, port):
    f = fly(launch, port, raised({1, 3, 5, 7}, delta=0.03))
    heading = f[17][2]
    p, q, r = xp.row16_pqr(f[16], 12)
    assert 180.0 < heading < 359.0                            # from 0 (north) to the left
    assert r < 0
    assert abs(f[17][0]) < 0.1 and abs(f[17][1]) < 0.1


def test_thrust_torque_units_and_climb(launch, port):
    u = [HOVER * 1.1] * 8
    f = fly(launch, port, u, 90)
    for j in range(8):
        assert f[35][j] == pytest.approx(KF * u[j] / xp.N_PER_LB, rel=1e-6)       # lb
        assert f[36][j] == pytest.approx(KTAU * u[j] / xp.NM_PER_FTLB, rel=1e-6)  # ft-lb, magnitude
    # climbing straight up: OpenGL +Y up, row 20 altitudes in feet, g normal 1.1
    t = f[1][2]
    a = (8 * KF * u[0] / 2.132) - 9.796
    z = 0.5 * a * t * t
    # OpenGL's origin is at sea level below the take-off point (default field 640 m MSL)
    assert f[21][1] - 640.0 == pytest.approx(z, rel=1e-3)
    assert f[21][4] == pytest.approx(a * t, rel=1e-3)         # vY
    assert f[20][3] == pytest.approx(z / xp.M_PER_FT, rel=1e-3)   # AGL ft
    assert f[4][4] == pytest.approx(1.1, rel=1e-4)            # g normal
    assert f[4][2] == pytest.approx(a * t / xp.M_PER_FT * 60, rel=1e-3)  # VVI ft/min
    assert f[21][0] == pytest.approx(0, abs=1e-6) and f[21][2] == pytest.approx(0, abs=1e-6)


def test_origin_and_tilted_flight_direction(launch, port, tmp_path):
    """Pitching nose up with thrust along +Z_B pushes the vehicle backwards (south,
    OpenGL +Z); lat/lon start at the vehicle file's origin."""
    veh = tmp_path / "v.json"
    veh.write_text('{"origin": [45.0, 7.5, 300.0]}')
    s = SimUnderTest(launch, port, "--lockstep", "--ideal", "--rows", ROWS, "--vehicle", str(veh))
    f0 = s.next_data()
    assert f0[20][0] == f32(45.0) and f0[20][1] == f32(7.5)
    assert f0[20][2] == pytest.approx(300.0 / xp.M_PER_FT, rel=1e-6)
    u = raised({8, 1, 2})
    f = s.start_lockstep(u)
    for _ in range(60):
        f = s.step(u)
    s.stop()
    assert f[17][0] > 1.0
    assert f[21][2] > 0.0 and f[21][5] > 0.0                 # moving south
    assert f[20][0] < 45.0                                    # latitude decreases
