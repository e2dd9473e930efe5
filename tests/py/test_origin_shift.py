"""Origin shifts: the plant moves X-Plane's local origin (octo-sim --shift-origin, vehicle key
origin_shift_s) and the firmware re-references, so that a flight with two shifts holds,
identifies and lands as the same flight without one (octo-sil: same seed, same mission).

The plant's part is checked on its own bytes: row 21's local position jumps by kilometres at
the shift time while row 20 (latitude, longitude, elevation) and the velocities do not.
"""

import json
import math
import re
import subprocess

import pytest

from conftest import BUILD
from test_fw_rig import read_log
from test_sim_support import SimUnderTest

MISSION = ("arm; takeoff 10; wait hold; sleep 5; experiment 1; wait experiment; sleep 3; "
           "land; wait disarmed")
SHIFTS = (20.0, 33.0)   # plant s: one in the experiment (HOLD follows it), one in the landing


def fly(tmp_path, name, *extra, vehicle=None, seed=3):
    fw, sim = tmp_path / f"{name}-fw.lcm", tmp_path / f"{name}-sim.lcm"
    argv = [BUILD / "octo-sil", "--seed", seed, "--mission", MISSION, "--lcm-fw", f"file://{fw}",
            "--lcm-sim", f"file://{sim}", *extra]
    if vehicle is not None:
        vf = tmp_path / f"{name}-vehicle.json"
        vf.write_text(json.dumps(vehicle))
        argv += ["--vehicle", vf]
    p = subprocess.run([str(a) for a in argv], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    said = [ln.split("octo-fw: ", 1)[1] for ln in p.stderr.splitlines() if "octo-fw: " in ln]
    return said, read_log(fw, "OCTO_FW_FRAME"), read_log(sim, "OCTO_TRUTH")


def estimates(said):
    """kf and ktau with their sds from the 'ID kf ...' / 'ID ktau ...' lines."""
    out = {}
    for t in said:
        m = re.match(r"ID (kf|ktau) ([\d.]+) \+/- ([\d.]+) .* accepted", t)
        if m:
            out[m.group(1)] = (float(m.group(2)), float(m.group(3)))
    return out


def hold_error(frames):
    """rms of the height error in HOLD (mode 3) after the first second of it, m"""
    hold = [f for f in frames if f.mode == 3 and f.stepped]
    t0 = hold[0].t + 1.0
    e = [f.pos_i[2] - f.z_sp for f in hold if f.t > t0]
    return math.sqrt(sum(x * x for x in e) / len(e))


@pytest.fixture(scope="module")
def flights(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("origin")
    plain = fly(tmp, "plain")
    shifted = fly(tmp, "shifted", *(a for t in SHIFTS for a in ("--shift-origin", t)))
    return plain, shifted


def test_the_firmware_sees_both_shifts(flights):
    (_, _, _), (said, _, _) = flights
    moved = [t for t in said if t.startswith("Plant moved its local origin")]
    assert len(moved) == 2, said
    for t in moved:   # kilometres, as X-Plane's scenery shifts
        assert int(re.search(r"\((\d+) m\)", t).group(1)) > 1000, t


def test_the_logged_position_has_no_step_and_matches_the_flight_without_shifts(flights):
    (_, fr0, _), (_, fr1, _) = flights
    for a, b in zip(fr1, fr1[1:]):
        if b.t > a.t:
            assert max(abs(b.pos_i[i] - a.pos_i[i]) for i in range(3)) < 0.5, (a.t, a.pos_i, b.pos_i)
    by_t = {round(f.t, 4): f for f in fr0}
    worst = 0.0
    n = 0
    for f in fr1:
        g = by_t.get(round(f.t, 4))
        if g is not None:
            n += 1
            worst = max(worst, max(abs(f.pos_i[i] - g.pos_i[i]) for i in range(3)))
    assert n > 1000
    assert worst < 0.05, worst   # the same flight to centimetres


def test_hold_identification_and_landing_as_without_shifts(flights):
    (said0, fr0, tr0), (said1, fr1, tr1) = flights
    assert "Landed" in said0 and "Landed" in said1
    e0, e1 = estimates(said0), estimates(said1)
    assert set(e0) == {"kf", "ktau"} and set(e1) == set(e0), (said0, said1)
    for k in e0:
        (v0, s0), (v1, s1) = e0[k], e1[k]
        assert abs(v0 - v1) < 0.5 * math.hypot(s0, s1), (k, e0[k], e1[k])
    h0, h1 = hold_error(fr0), hold_error(fr1)
    assert h1 < 0.05 and abs(h1 - h0) < 0.01, (h0, h1)
    # the truth: both end on the ground near where they took off, the same way
    end0, end1 = tr0[-1].pos_i, tr1[-1].pos_i
    assert abs(end0[2] - end1[2]) < 0.01
    assert math.hypot(end0[0] - end1[0], end0[1] - end1[1]) < 0.1


def test_the_plant_shifts_row_21_and_not_row_20(launch, port, tmp_path):
    """octo-sim's bytes: at the shift row 21's x/y/z jump by kilometres; row 20 (latitude,
    longitude, elevation) and the velocities go on as before. The vehicle file's key and the
    flag add up (two shifts)."""
    vf = tmp_path / "v.json"
    vf.write_text(json.dumps({"origin_shift_s": [0.3]}))
    s = SimUnderTest(launch, port, "--ideal", "--lockstep", "--vehicle", vf, "--shift-origin", "0.6",
                     rows=(1, 20, 21))
    f = s.start_lockstep([0.0] * 8)
    frames = [f]
    while frames[-1][1][2] < 0.9:
        frames.append(s.step([0.0] * 8))
    jumps = []
    for a, b in zip(frames, frames[1:]):
        d21 = max(abs(b[21][i] - a[21][i]) for i in range(3))
        if d21 > 1000.0:
            jumps.append(b[1][2])
        else:
            assert d21 < 0.01, (a[1][2], a[21], b[21])
        assert abs(b[20][0] - a[20][0]) < 1e-5 and abs(b[20][1] - a[20][1]) < 1e-5, (a[20], b[20])
        assert abs(b[20][2] - a[20][2]) < 0.01, (a[20], b[20])
        assert max(abs(b[21][i] - a[21][i]) for i in range(3, 6)) < 0.01
    assert len(jumps) == 2, jumps
    assert abs(jumps[0] - 0.3) < 0.02 and abs(jumps[1] - 0.6) < 0.02, jumps


def test_bad_shift_times_are_refused(launch, port, tmp_path):
    for args in (["--shift-origin", "-1"], ["--shift-origin", "x"]):
        p = subprocess.run([str(BUILD / "octo-sim"), *args], capture_output=True, text=True, timeout=10)
        assert p.returncode == 2 and "--shift-origin" in p.stderr, p.stderr
    vf = tmp_path / "v.json"
    vf.write_text(json.dumps({"origin_shift_s": 5}))
    p = subprocess.run([str(BUILD / "octo-sim"), "--vehicle", vf], capture_output=True, text=True, timeout=10)
    assert p.returncode == 2 and "origin_shift_s" in p.stderr, p.stderr
