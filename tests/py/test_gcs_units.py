"""Unit tests of octo_gcs pieces that need no vehicle: parameter files, the model."""

import math
import os
import random

import numpy as np
import pytest

from octo_gcs import paramfile
from octo_gcs.model import Model, Params, State, gamma_o
from octo_gcs.commands.params import diff


# ------------------------------------------------------------ parameter files
def test_paramfile_round_trip_mavproxy_format(tmp_path):
    rng = random.Random(7)
    params = {f"P{i:02d}_{rng.choice('ABC')}": rng.uniform(-100, 100) for i in range(20)}
    path = tmp_path / "x.parm"
    paramfile.save(path, params)
    text = path.read_text()
    # MAVProxy's layout: sorted, 16-character name column, %f
    lines = text.splitlines()
    assert lines == sorted(lines)
    assert all(len(line.split()[0]) <= 16 and line[16] == " " for line in lines)
    back = paramfile.load(path)
    assert back.keys() == params.keys()
    for k, v in params.items():
        assert back[k] == pytest.approx(v, abs=5e-7)
    assert not [p for p in os.listdir(tmp_path) if p != "x.parm"], "temporary file left behind"


def test_paramfile_reads_what_mavproxy_writes_and_accepts():
    text = "# saved by MAVProxy\nVEH_KF           28.026900\nVEH_KTAU,0.3869  # trailing comment\n\n  VEH_IXX 6.28e-2\nX 0x10\n"
    assert paramfile.parse(text) == {"VEH_KF": 28.0269, "VEH_KTAU": 0.3869, "VEH_IXX": 0.0628, "X": 16.0}


def test_paramfile_reports_every_damaged_line_with_its_number():
    text = "A 1\nB\nC nan\nD 1 2\nTHIS_NAME_IS_TOO_LONG 1\nE x\nA 2\nF inf\n"
    with pytest.raises(paramfile.ParamFileError) as e:
        paramfile.parse(text, "t.parm")
    assert [n for n, _ in e.value.problems] == [2, 3, 4, 5, 6, 7, 8]
    assert "t.parm" in str(e.value) and "line 6" in str(e.value)


def test_diff_compares_as_float32():
    assert diff({"A": 0.1, "B": 1.0}, {"A": 0.1 + 1e-12, "B": 2.0, "C": 3.0}) == [
        ("B", 1.0, 2.0), ("C", None, 3.0)]


# ------------------------------------------------------------ the analytical model
def test_gamma_matches_eq14_geometry():
    """Each column is [1, y_j, -x_j, +/-k] for rotor j at -(j-1)*45 deg (Y left, clockwise from front)."""
    l, k = 0.35, 0.0138
    G = gamma_o(l, k)
    for j in range(8):
        a = -j * math.pi / 4
        x, y = l * math.cos(a), l * math.sin(a)
        assert G[:, j] == pytest.approx([1, y, -x, k if j % 2 == 0 else -k], abs=1e-12)


def test_hover_and_free_fall_are_exact():
    p = Params()
    m = Model(p)
    T = p.mass * p.g / (8 * p.kf)
    xs = m.simulate(State().vector(), [m.wrench_of_throttles([T] * 8)] * 5000, 0.002)
    assert np.abs(xs[-1][:3]).max() < 1e-9
    xs = m.simulate(State().vector(), [np.zeros(4)] * 500, 0.002)
    assert xs[-1][2] == pytest.approx(-0.5 * p.g * 1.0 ** 2, rel=1e-12)


def test_torque_free_tumble_conserves_momentum_and_energy():
    rng = np.random.default_rng(3)
    I = rng.uniform(0.03, 0.12, 3)
    m = Model(Params(inertia=tuple(I)))
    x0 = State(w=rng.uniform(-3, 3, 3)).vector()
    xs = m.simulate(x0, [np.zeros(4)] * 2000, 0.005)

    def h_inertial(x):
        from octo_gcs.model import quat_to_rot
        return quat_to_rot(x[6:10]) @ (I * x[10:13])

    e0 = 0.5 * np.sum(I * x0[10:13] ** 2)
    for x in xs[::200]:
        assert np.linalg.norm(h_inertial(x) - h_inertial(x0)) / np.linalg.norm(h_inertial(x0)) < 1e-7
        assert abs(0.5 * np.sum(I * x[10:13] ** 2) - e0) / e0 < 1e-9


def test_rk4_error_falls_sixteen_fold_when_step_halves():
    rng = np.random.default_rng(5)
    I = (0.0628, 0.0762, 0.1014)
    m = Model(Params(inertia=I))
    x0 = State(w=np.array([2.0, -1.5, 3.0])).vector()
    u = [np.array([0.0, 0.01, -0.02, 0.005])]
    ref = m.simulate(x0, u * 4000, 0.0005)[-1]
    e1 = np.linalg.norm(m.simulate(x0, u * 200, 0.01)[-1][10:13] - ref[10:13])
    e2 = np.linalg.norm(m.simulate(x0, u * 400, 0.005)[-1][10:13] - ref[10:13])
    assert 12 < e1 / e2 < 20
    del rng


# ------------------------------------------------------------ long status lines
def test_link_joins_statustext_chunks_and_marks_a_lost_one():
    """octo-fw sends a line longer than 50 characters as STATUSTEXT chunks (one nonzero id,
    chunk_seq 0, 1, ..., the last not full); octo-gcs shows it whole, from each sender apart."""
    from octo_gcs.link import Vehicle, mavlink

    rng = random.Random()
    line = "".join(rng.choice("abcdefghij ") for _ in range(rng.randint(51, 149)))
    link = object.__new__(Vehicle)   # no socket: only the joining is under test
    link._chunks = {}

    def chunk(sysid, text, cid, seq):
        mav = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=1)
        m = mav.statustext_encode(4, text.encode(), cid, seq)
        return mav.decode(bytearray(m.pack(mav)))

    parts = [line[i:i + 50] for i in range(0, len(line), 50)]
    if len(parts[-1]) == 50:
        parts.append("")
    out = []
    for seq, part in enumerate(parts):
        out.append(link._join_chunks(chunk(1, part, 7, seq)))
        out.append(link._join_chunks(chunk(2, "other vehicle, short", 0, 0)))
    assert out[-2] == line and all(o is None for o in out[:-2:2])
    assert out[1::2] == ["other vehicle, short"] * len(parts)
    # chunk 1 of 3 lost: the line still ends, the gap marked
    text = "x" * 50 + "y" * 50 + "z"
    assert link._join_chunks(chunk(1, text[:50], 8, 0)) is None
    assert link._join_chunks(chunk(1, text[100:], 8, 2)) == "x" * 50 + "[...]" + "z"
    # chunk 0 of a line lost: marked once
    assert link._join_chunks(chunk(1, text[50:100], 9, 1)) is None
    assert link._join_chunks(chunk(1, text[100:], 9, 2)) == "[...]" + "y" * 50 + "z"
