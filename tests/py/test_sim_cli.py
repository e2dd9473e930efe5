"""octo-sim's command line: --help, clear errors for bad flags and bad --vehicle
files (exit 2 naming the flag or the key), vehicle files applied, --verbose."""

import json
import subprocess

import pytest

import xplane_proto as xp
from conftest import binary, wait_until
from test_sim_support import HOVER, KF, SimUnderTest


def run(*args):
    return subprocess.run([binary("octo-sim"), *map(str, args)], capture_output=True, text=True, timeout=10)


def test_help_lists_every_flag():
    r = run("--help")
    assert r.returncode == 0 and r.stdout.startswith("usage: octo-sim")
    for flag in ("--xp-port", "--data-out", "--rate", "--xplane-version", "--vehicle", "--seed",
                 "--duration", "--lcm", "--lockstep", "--lockstep-timeout", "--ideal", "--rows",
                 "--drop", "--burst", "--burst-prob", "--delay-frames", "--duplicate", "--reorder",
                 "--verbose", "--bind"):
        assert flag in r.stdout, flag


@pytest.mark.parametrize("args,flag", [
    (["--bogus"], "--bogus"),
    (["--rate", "fast"], "--rate"),
    (["--rate", "0"], "--rate"),
    (["--rate"], "--rate"),
    (["--xp-port", "70000"], "--xp-port"),
    (["--xplane-version", "10"], "--xplane-version"),
    (["--data-out", "localhost"], "--data-out"),
    (["--data-out", "127.0.0.1:0"], "--data-out"),
    (["--drop", "1.5"], "--drop"),
    (["--duplicate", "-0.1"], "--duplicate"),
    (["--burst", "x"], "--burst"),
    (["--delay-frames", "-1"], "--delay-frames"),
    (["--seed", "-4"], "--seed"),
    (["--rows", "1,,3"], "--rows"),
    (["--duration", "nan"], "--duration"),
])
def test_bad_flags_exit_2_naming_the_flag(args, flag):
    r = run(*args)
    assert r.returncode == 2, r.stderr
    assert flag in r.stderr


@pytest.mark.parametrize("text,key", [
    ('{"mass": 0}', "mass"),
    ('{"mass": -1.0}', "mass"),
    ('{"inertia": [0.06, 0.0, 0.1]}', "inertia"),
    ('{"inertia": [0.06, 0.07]}', "inertia"),
    ('{"kf": "28"}', "kf"),
    ('{"massive": 3}', "massive"),
    ('{"noise": {"gyro": -1}}', "noise.gyro"),
    ('{"noise": {"sonar": 1}}', "noise.sonar"),
    ('{"rotor_scale": [1, 1, 1]}', "rotor_scale"),
    ('{"thrust_curve": 1.5}', "thrust_curve"),
    ('{"origin": [95, 0, 0]}', "origin"),
    ('{"g": NaN}', "'g'"),
    ('{"kf": Infinity}', "'kf'"),
    ('{"mass": 2.0 x}', "JSON"),
    ('{"mass": 2.0,}', "JSON"),
    ('[1, 2]', "object"),
])
def test_bad_vehicle_files_exit_2_naming_the_key(tmp_path, text, key):
    f = tmp_path / "v.json"
    f.write_text(text)
    r = run("--vehicle", f)
    assert r.returncode == 2, r.stderr
    assert "--vehicle" in r.stderr and key in r.stderr, r.stderr


@pytest.mark.parametrize("text,key,value,accepted", [
    ('{"kf_drift_per_min": -2}', "kf_drift_per_min", "-2", "[-0.2, 0.2]"),
    ('{"kf_drift_per_min": 0.25}', "kf_drift_per_min", "0.25", "[-0.2, 0.2]"),
    ('{"mass": 0}', "mass", "0", "> 0"),
    ('{"mass": -1.5}', "mass", "-1.5", "> 0"),
    ('{"inertia": [0.06, -0.07, 0.1]}', "inertia", "-0.07", "> 0"),
    ('{"inertia": [0.06, 0.07, 0.14]}', "inertia", "Iz = 0.14", "<= 0.13"),
    ('{"inertia": [0.3, 0.07, 0.1]}', "inertia", "Ix = 0.3", "<= 0.17"),
    ('{"mass": 5, "kf": 6}', "kf", "kf' = 6", "kf >= 6.1225"),
    ('{"noise": {"gyro": -0.001}}', "noise.gyro", "-0.001", ">= 0"),
    ('{"noise": {"thrust": -1}}', "noise.thrust", "-1", ">= 0"),
])
def test_implausible_vehicle_files_name_key_value_and_range(tmp_path, text, key, value, accepted):
    f = tmp_path / "v.json"
    f.write_text(text)
    r = run("--vehicle", f)
    assert r.returncode == 2, r.stderr
    assert f"'{key}'" in r.stderr and value in r.stderr and accepted in r.stderr, r.stderr


def test_plausible_extremes_are_accepted(tmp_path):
    """The envelope's corners (hover throttle 0.6 at 5 kg, drift -20 %/min, a flat disc
    Iz = Ix + Iy) pass."""
    f = tmp_path / "v.json"
    f.write_text(json.dumps({"mass": 5.0, "kf": 5.0 * 9.796 / (8 * 0.6), "kf_drift_per_min": -0.2,
                             "inertia": [0.05, 0.07, 0.12], "noise": {"gyro": 0.0}}))
    r = run("--vehicle", f, "--duration", "0.05")
    assert r.returncode == 0, r.stderr


def test_missing_vehicle_file(tmp_path):
    r = run("--vehicle", tmp_path / "nope.json")
    assert r.returncode == 2 and "cannot read" in r.stderr


def test_busy_port_is_a_clear_error(launch, port):
    s = SimUnderTest(launch, port)
    r = run("--xp-port", s.xp_port)
    assert r.returncode == 1 and "--xp-port" in r.stderr


def test_vehicle_file_is_applied(launch, port, tmp_path):
    f = tmp_path / "v.json"
    f.write_text(json.dumps({"kf": 20.0, "ktau": 0.5, "rotor_scale": [1, 1, 1, 1, 1, 1, 1, 0.5],
                             "noise": {"thrust": 0, "torque": 0}}))
    s = SimUnderTest(launch, port, "--lockstep", "--vehicle", f, "--rows", "35,36")
    u = [0.2] * 8
    fr = s.start_lockstep(u)
    for _ in range(20):
        fr = s.step(u)
    assert fr[35][0] == pytest.approx(20.0 * 0.2 / xp.N_PER_LB, rel=1e-3)   # lag settled (0.24 s)
    assert fr[35][7] == pytest.approx(0.5 * 20.0 * 0.2 / xp.N_PER_LB, rel=1e-3)
    assert fr[36][0] == pytest.approx(0.5 * 0.2 / xp.NM_PER_FTLB, rel=1e-3)


def test_default_noise_and_lag_are_on(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--rows", "16,26,35")
    u = [0.5] * 8
    fr = s.start_lockstep(u)
    assert 0.1 < fr[26][0] < 0.25                             # 30 ms lag after one 11 ms frame
    for _ in range(60):
        fr = s.step(u)
    assert fr[26][0] == pytest.approx(0.5, abs=1e-6)
    thrust = [x * xp.N_PER_LB for x in fr[35]]
    assert all(abs(t - KF * 0.5) < 0.2 for t in thrust) and len(set(thrust)) == 8


def test_verbose_status_line(launch, port):
    s = SimUnderTest(launch, port, "--verbose", "--rate", "90")
    assert wait_until(lambda: "octo-sim: t=" in s.proc.stderr(), timeout=4)
