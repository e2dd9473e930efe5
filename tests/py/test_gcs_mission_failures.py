"""`octo-gcs mission` when a phase reaches its limit: it stops, keeps what it has in
DIR/failed-run/ (the logs and a report naming the phase and the reason) and exits
non-zero with the vehicle's reason, never just "octo-sim exited".

The seeds, limits and vehicles are drawn anew each run from a printed seed; OCTO_FAIL_SEED=N
repeats a draw (each test draws from N and its own name)."""

import json
import os
import random
import re
import subprocess

import pytest

from conftest import BUILD, REPO

GCS = REPO / ".venv" / "bin" / "octo-gcs"


@pytest.fixture
def rng(request):
    """This test's draw: from OCTO_FAIL_SEED (printed) and the test's name."""
    seed = int(os.environ.get("OCTO_FAIL_SEED", random.SystemRandom().randrange(1, 10**6)))
    print(f"OCTO_FAIL_SEED={seed}")
    return random.Random(f"{seed}:{request.node.name}")


def gcs(*args, timeout=120):
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    return subprocess.run([str(GCS), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=env, stdin=subprocess.DEVNULL)


def failed_report(out):
    d = out / "failed-run"
    rep = json.loads((d / "report.json").read_text())
    md = (d / "report.md").read_text()
    for f in ("truth.lcm", "fw.lcm", "octo-sim.log", "octo-fw.log"):
        assert (d / f).exists(), f
    assert not (out / "report.json").exists()
    return rep, md


@pytest.mark.parametrize("param,phase,reason", [
    ("NAV_TKO_TO=1", "take-off", "Take-off failed: NAV_TKO_TO 1 s"),
    ("NAV_LAND_TO=1", "landing", "Landing failed: NAV_LAND_TO 1 s"),
])
def test_phase_limit_stops_the_mission_with_its_reason(tmp_path, param, phase, reason, rng):
    out = tmp_path / "out"
    r = gcs("mission", "--experiments", "none", "--param", param, "--seed", rng.randint(1, 999), "--out", out)
    assert r.returncode != 0, r.stdout
    last = r.stderr.strip().splitlines()
    assert any(f"{phase} failed: {reason}" in line for line in last), r.stderr
    assert "octo-sim exited" not in r.stderr
    rep, md = failed_report(out)
    assert rep["pass"] is False and rep["failed_phase"] == phase and reason in rep["failure"]
    assert f"phase: {phase}" in md and reason in md


def test_impossible_vehicle_take_off_fails_with_reason(tmp_path):
    """Hover throttle 0.99 with MOT_THR_MAX 0.5: the vehicle cannot leave the ground; the
    take-off limit says how far it got and that the hover throttle was not learned."""
    vf = tmp_path / "v.json"
    mass = 2.0
    vf.write_text(json.dumps({"mass": mass, "kf": mass * 9.796 / (8 * 0.99)}))
    out = tmp_path / "out"
    r = gcs("mission", "--vehicle", vf, "--experiments", "none", "--param", "MOT_THR_MAX=0.5",
            "--param", "NAV_TKO_TO=10", "--out", out)
    assert r.returncode != 0
    assert re.search(r"take-off failed: Take-off failed: NAV_TKO_TO 10 s, -?0\.0\d/10\.00 m", r.stderr), r.stderr
    assert "not learned" in r.stderr
    rep, _ = failed_report(out)
    assert rep["failed_phase"] == "take-off"


def underpowered_vehicle(tmp_path, rng):
    """A vehicle with a random hover throttle and 1-2 % of thrust to spare (MOT_THR_MAX): it
    climbs more slowly than the take-off's height profile, whose set point reaches the target
    seconds before the vehicle does (the hold entry then lasts)."""
    mass, u_h = rng.uniform(1.0, 5.0), rng.uniform(0.15, 0.5)
    kf = mass * 9.796 / (8 * u_h)
    vf = tmp_path / "v.json"
    vf.write_text(json.dumps({"mass": mass, "kf": kf, "ktau": 0.3869 * kf / 28.0269}))
    return vf, u_h * rng.uniform(1.01, 1.02)


def test_hold_entry_limit_stops_the_mission_with_its_reason(tmp_path, rng):
    """The take-off's set point at 10 m, the underpowered vehicle still climbing: NAV_HOLD_TO
    runs out; the exit message names the hold entry, the limit and how far off the vehicle is."""
    vf, thr_max = underpowered_vehicle(tmp_path, rng)
    out = tmp_path / "out"
    r = gcs("mission", "--vehicle", vf, "--experiments", "none", "--param", "NAV_HOLD_TO=1",
            "--param", f"MOT_THR_MAX={thr_max:.4f}", "--seed", rng.randint(1, 999), "--out", out)
    assert r.returncode != 0, r.stdout
    assert re.search(r"hold entry failed: Hold entry failed: NAV_HOLD_TO 1 s; "
                     r"Still -\d\.\d{3} m \+\d\.\d{3} m/s off the target", r.stderr), r.stderr
    rep, md = failed_report(out)
    assert rep["failed_phase"] == "hold entry" and "NAV_HOLD_TO 1 s" in rep["failure"]
    assert "phase: hold entry" in md


def test_hold_entry_within_its_default_limit(tmp_path, rng):
    """The same kind of vehicle with the default NAV_HOLD_TO reaches HOLD: the limit above
    failed on time, not on a vehicle that cannot hold."""
    vf, thr_max = underpowered_vehicle(tmp_path, rng)
    out = tmp_path / "out"
    r = gcs("mission", "--vehicle", vf, "--experiments", "none",
            "--param", f"MOT_THR_MAX={thr_max:.4f}", "--seed", rng.randint(1, 999), "--out", out, "--no-plots")
    assert r.returncode == 0 and "Hold entry failed" not in r.stderr + r.stdout, r.stdout + r.stderr


@pytest.mark.parametrize("experiment,param,phase", [
    ("1", "ID_ROT_TO", "rotor coefficients"),
    ("2", "ID_VAL_TO", "validation"),
    ("5", "ID_INR_TO", "inertia Izz"),
    ("6", "ID_INR_TO", "inertia Ixx"),   # the sequence: its first inertia phase
])
def test_experiment_limit_stops_the_mission_with_its_reason(tmp_path, experiment, param, phase, rng):
    """A phase limit shorter than the phase (1 s of settling + 5 or 10 s, + 1.5 s in the rotor
    phase): the experiment fails
    with the limit and the phase's planned time; the mission stops and names them."""
    limit = round(rng.uniform(1.5, 4.5), 1)
    out = tmp_path / "out"
    r = gcs("mission", "--experiments", experiment, "--param", f"{param}={limit}",
            "--seed", rng.randint(1, 999), "--out", out)
    assert r.returncode != 0, r.stdout
    # settling 1 s + excitation 5 s (validation) or 10 s, and the rotor phase's 1.5 s after its
    # last sweep step
    planned = {"ID_VAL_TO": 6.0, "ID_ROT_TO": 12.5}.get(param, 11.0)
    why = f"ID {phase} failed: {param} {limit:.1f} s"
    assert f"experiment {experiment} " in r.stderr and f"failed: {why}; aborted: time limit, " \
        f"phase planned {planned:.1f} s" in r.stderr, r.stderr
    rep, md = failed_report(out)
    assert rep["failed_phase"] == f"experiment {experiment}" and why in rep["failure"]
    assert why in rep["vehicle_errors"]


@pytest.mark.parametrize("param,step,reason", [
    ("NAV_TKO_TO=1", "wait hold", "Take-off failed: NAV_TKO_TO 1 s"),
    ("NAV_LAND_TO=1", "wait disarmed", "Landing failed: NAV_LAND_TO 1 s"),
    ("ID_ROT_TO=2", "wait experiment", r"experiment ended FAILED \(ID rotor coefficients failed: ID_ROT_TO 2\.0 s"),
])
def test_phase_limit_stops_the_in_process_mission_with_its_reason(tmp_path, param, step, reason, rng):
    """octo-sil: the firmware's final FAILED ends the waiting step at once; octo-sil exits
    non-zero naming the step and the firmware's reason, and the logs are kept."""
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--experiments", "1" if param.startswith("ID_") else "none", "--param", param,
            "--seed", rng.randint(1, 999), "--out", out)
    assert r.returncode != 0, r.stdout
    assert re.search(rf"step \d+ '{step}' failed at t=[0-9.]+ s: {reason}", r.stderr), r.stderr
    assert "still in mode" not in r.stderr   # not the step's own time limit
    assert (out / "failed-run" / "octo-sil.log").exists()
    assert not (out / "report.json").exists()


def test_in_process_mission_without_experiments(tmp_path, rng):
    """Take-off, hold entry and landing alone in octo-sil, with the underpowered vehicle: the
    firmware stores no result (no experiment), the mission still reports and passes."""
    vf, thr_max = underpowered_vehicle(tmp_path, rng)
    out = tmp_path / "out"
    r = gcs("mission", "--in-process", "--vehicle", vf, "--experiments", "none",
            "--param", f"MOT_THR_MAX={thr_max:.4f}", "--seed", rng.randint(1, 999), "--out", out, "--no-plots")
    assert r.returncode == 0, r.stdout + r.stderr
    rep = json.loads((out / "report.json").read_text())
    assert rep["pass"] and (out / "params.parm").exists() and not (out / "failed-run").exists()


def test_a_port_taken_at_start_is_retried_on_fresh_ports(tmp_path, monkeypatch, capsys, rng):
    """A port chosen free can be bound by another program before octo-sim or octo-fw binds it
    (two missions starting together): the mission says so and starts again on fresh ports.
    The first port handed out here is held by the test, so the first start must fail."""
    import socket

    from octo_gcs import cli, procs

    monkeypatch.setenv("OCTO_BUILD", str(BUILD))
    held = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    held.bind(("127.0.0.1", 0))
    taken = held.getsockname()[1]
    real, calls = procs.free_udp_port, []

    def first_taken():
        calls.append(1)
        return taken if len(calls) == 1 else real()

    monkeypatch.setattr(procs, "free_udp_port", first_taken)
    out = tmp_path / "out"
    try:
        rc = cli.main(["mission", "--experiments", "none", "--seed", str(rng.randint(1, 999)),
                       "--no-plots", "--out", str(out)])
    finally:
        held.close()
    said = capsys.readouterr()
    assert rc == 0, said.out + said.err
    assert re.search(rf"a UDP port was taken before a program bound it \(.*{taken}.*\); "
                     r"retrying on fresh ports \(2 of 4\)", said.out + said.err), said.out + said.err
    assert len(calls) == 6 and (out / "report.json").exists()


def test_a_port_always_taken_at_start_fails_with_the_reason(tmp_path, monkeypatch, capsys):
    """Every start finds its port taken: after PORT_ATTEMPTS starts the mission fails, naming
    the port and the program that could not bind it."""
    import socket

    from octo_gcs import cli, procs
    from octo_gcs.mission import flying_udp

    monkeypatch.setenv("OCTO_BUILD", str(BUILD))
    held = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    held.bind(("127.0.0.1", 0))
    taken = held.getsockname()[1]
    monkeypatch.setattr(procs, "free_udp_port", lambda: taken)
    try:
        rc = cli.main(["mission", "--experiments", "none", "--no-plots", "--out", str(tmp_path / "out")])
    finally:
        held.close()
    err = capsys.readouterr().err
    assert rc != 0
    assert f"cannot bind 127.0.0.1:{taken}: Address already in use" in err, err
    assert f"taken at start {flying_udp.PORT_ATTEMPTS} times in a row" in err, err
    rep = json.loads((tmp_path / "out" / "failed-run" / "report.json").read_text())
    assert rep["failed_phase"] == "start" and "octo-sim exited with status 1" in rep["failure"]
