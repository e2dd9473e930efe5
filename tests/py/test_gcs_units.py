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


# ------------------------------------------------------------ mission options: build, sensors, plant time
def test_mission_options_build_sensors_and_plant_time_reach_the_plants_flags(tmp_path):
    from octo_gcs.mission import flying_sil, flying_udp
    from octo_gcs.mission.options import MissionOptions, plant_flags

    o = MissionOptions(plant="sil", build="fixed", sensors="thrust,torque,imu,rpm", start_time=4e4,
                       shift_origin=[30, 12.5], faults={"drop": 0.02})
    assert o.sensors == ["imu", "rpm", "torque", "thrust"]   # each once, in the plant's order
    assert plant_flags(o) == ["--sensors", "imu,rpm,torque,thrust", "--start-time", "40000.0",
                              "--shift-origin", "30.0", "--shift-origin", "12.5", "--drop", "0.02"]
    sil = [str(a) for a in flying_sil.sil_argv(tmp_path, o, tmp_path, 300.0)]
    assert sil[0].endswith("/octo-sil-fixed") and sil[-len(plant_flags(o)):] == plant_flags(o)
    assert "--script" in sil and "--mission" not in sil
    u = MissionOptions(sensors=["imu"], start_time=0.0)
    assert plant_flags(u) == ["--sensors", "imu"]   # start time 0: the plant's default, no flag
    sim = [str(a) for a in flying_udp.sim_argv(tmp_path, u, (1, 2, 3, 4), tmp_path, 300.0)]
    assert sim[0].endswith("/octo-sim") and sim[-2:] == ["--sensors", "imu"]
    fw = [str(a) for a in flying_udp.fw_argv(tmp_path, (1, 2, 3, 4), tmp_path, "octo-fw-fixed")]
    assert fw[0].endswith("/octo-fw-fixed")
    assert MissionOptions.from_json(o.to_json()) == o


@pytest.mark.parametrize("kw, names", [
    ({"build": "double"}, "build 'double'"),
    ({"sensors": "imu,gps"}, "unknown sensor 'gps'"),
    ({"sensors": []}, "sensors"),
    ({"start_time": -1}, "start time -1"),
    ({"start_time": "soon"}, "start time 'soon'"),
    ({"shift_origin": [5, 2e9]}, "origin shift time 2000000000.0"),
])
def test_mission_options_errors_name_the_option_and_value(kw, names):
    from octo_gcs.base import GcsError
    from octo_gcs.mission.options import MissionOptions

    with pytest.raises(GcsError) as e:
        MissionOptions(**kw)
    assert names in str(e.value)


def test_mission_command_line_fixed_sensors_start_time_shift_origin():
    import argparse

    from octo_gcs.base import GcsError
    from octo_gcs.commands import mission

    p = argparse.ArgumentParser()
    mission.register(p.add_subparsers())
    a = p.parse_args(["mission", "--fixed", "--in-process", "--sensors", "thrust,torque,imu,rpm",
                      "--start-time", "1e5", "--shift-origin", "20", "--shift-origin", "40",
                      "--fault", "drop=0.01"])
    o = mission.options(a)
    assert (o.plant, o.build, o.sensors) == ("sil", "fixed", ["imu", "rpm", "torque", "thrust"])
    assert o.start_time == 1e5 and o.shift_origin == [20.0, 40.0] and o.faults == {"drop": 0.01}
    d = mission.options(p.parse_args(["mission"]))
    assert (d.build, d.sensors, d.start_time, d.shift_origin) == ("float", None, 0.0, [])
    with pytest.raises(GcsError, match="--sensors: unknown sensor 'baro'"):
        mission.options(p.parse_args(["mission", "--sensors", "imu,baro"]))


# ------------------------------------------------------------ vehicle files: the plant's sensor keys
def test_vehicle_file_accepts_the_plants_sensor_and_fault_keys():
    import json

    from octo_gcs import vehiclefile

    v = {"noise": {"accel": 0.05, "rpm": 20, "current": 0.1, "gyro": 0.01},
         "imu_bias": {"accel": 0.05, "gyro": 0.002, "accel_walk": 1e-4, "gyro_walk": 1e-5},
         "imu_scale": 0.005, "vibration": {"accel": 1.0, "gyro": 0.05, "harmonics": [1, 0.3, 0.1],
                                           "cutoff_hz": 30, "sample_hz": 1000},
         "rpm_max": 9000, "esc_pole_pairs": 7, "esc_kt": 0.0136, "esc_current_offset": 0.2,
         "sensors": ["imu", "rpm"], "origin_shift_s": [30, 60]}
    assert vehiclefile.parse(json.dumps(v))["sensors"] == ["imu", "rpm"]


@pytest.mark.parametrize("bad, names", [
    ({"imu_bias": {"acc": 0.1}}, "unknown key 'imu_bias.acc'"),
    ({"noise": {"baro": 0.1}}, "unknown key 'noise.baro'"),
    ({"vibration": {"harmonic": [1]}}, "unknown key 'vibration.harmonic'"),
    ({"vibration": 3}, "key 'vibration' must be an object"),
    ({"sensors": ["imu", "gps"]}, "unknown sensor \"gps\""),
    ({"sensors": []}, "key 'sensors'"),
    ({"esc_kv": 700}, "unknown key 'esc_kv'"),
])
def test_vehicle_file_errors_name_the_key(bad, names):
    import json

    from octo_gcs import vehiclefile

    with pytest.raises(vehiclefile.VehicleFileError) as e:
        vehiclefile.parse(json.dumps(bad), "v.json")
    assert names in str(e.value) and "v.json" in str(e.value)


# ------------------------------------------------------------ waiting for a mode
class _FakeVehicle:
    """A link.Vehicle stand-in whose mode becomes `mode_at` when its clock reaches `t_at`."""

    def __init__(self, clock, t_at, mode_at):
        self.mode, self.clock, self.t_at, self.mode_at = 3, clock, t_at, mode_at

    def recv(self, types=(), timeout=0.05):
        if self.clock() is not None and self.clock() >= self.t_at:
            self.mode = self.mode_at

    def _last_text(self, since=None):
        return "Mode LAND"


def test_wait_mode_in_lockstep_counts_the_simulated_time_and_names_a_stall(monkeypatch):
    """Lockstep on a slow host (an emulated processor on a busy machine): the landing takes
    20 s of simulated time at a fifth of real time, 100 s of wall time; the wait bounded by
    30 s counts the vehicle's time and succeeds. A landing that needs 40 s of simulated time
    fails naming the simulated bound; a clock standing still fails as a stall."""
    from octo_gcs import flight as flight_mod
    from octo_gcs.flight import Flight
    from octo_gcs.link import GcsError

    wall = [0.0]
    monkeypatch.setattr(flight_mod.time, "monotonic", lambda: wall[0])

    def slow_clock():  # each poll advances 0.05 s of wall time, 0.01 s simulated
        wall[0] += 0.05
        return 100.0 + wall[0] / 5.0

    for need, ok in ((20.0, True), (40.0, False)):
        wall[0] = 0.0
        v = _FakeVehicle(slow_clock, 100.0 + need, 0)
        fl = Flight(v)
        if ok:
            fl.wait_mode({"DISARMED"}, 30.0, "landing", clock=slow_clock)
            assert wall[0] > 30.0 * 3, "the wait was not bounded by the wall clock"
        else:
            with pytest.raises(
                GcsError,
                match=r"landing: vehicle still in mode HOLD after 30 s simulated",
            ):
                fl.wait_mode({"DISARMED"}, 30.0, "landing", clock=slow_clock)
    # without a clock the bound is the wall's
    wall[0] = 0.0
    v = _FakeVehicle(slow_clock, 120.0, 0)
    with pytest.raises(GcsError, match=r"after 30 s \("):
        Flight(v).wait_mode({"DISARMED"}, 30.0, "landing")

    def stuck():
        wall[0] += 0.05
        return 7.5

    wall[0] = 0.0
    with pytest.raises(
        GcsError, match=r"simulated time stood still for 30 s of wall time at t=7.50 s"
    ):
        Flight(_FakeVehicle(stuck, 1e9, 0)).wait_mode(
            {"DISARMED"}, 30.0, "landing", clock=stuck
        )


def test_experiment_bound_in_lockstep_counts_the_simulated_time_and_names_a_stall(monkeypatch):
    """The experiment's limit (identify._Bound): with the simulated time, `timeout` s of it
    however slowly it runs, and a stall of 30 s of wall time named; without it, the wall's."""
    from octo_gcs import identify

    wall = [0.0]
    monkeypatch.setattr(identify.time, "monotonic", lambda: wall[0])
    sim = [50.0]
    b = identify._Bound(100.0, lambda: sim[0])
    for _ in range(1000):  # 1,000 s of wall time, 99 s simulated: within
        wall[0] += 1.0
        sim[0] += 0.099
        assert b.exceeded() is None
    sim[0] += 2.0
    assert b.exceeded() == "still running after 100 s simulated"
    b = identify._Bound(100.0, lambda: sim[0])
    wall[0] += 29.0
    assert b.exceeded() is None
    wall[0] += 2.0
    assert b.exceeded() == f"stopped: the simulated time stood still for 30 s of wall time at t={sim[0]:.2f} s"
    b = identify._Bound(100.0)
    wall[0] += 99.0
    assert b.exceeded() is None
    wall[0] += 2.0
    assert b.exceeded() == "still running after 100 s"
