"""A failed rotor survived (docs/rotor-failure.md), flown in octo-sil.

The plant cuts a rotor (`--fail-rotor J@T`) in hover, in the take-off's climb and in the
middle of the rotor experiment (1) and of each inertia experiment (3, 4, 5), for each of the 8
rotors. From the truth log (OCTO_TRUTH) and the firmware's log (its frames and events):
  - the firmware names the right rotor within 0.5 s of the failure;
  - from the failure to the touch-down the attitude stays within 15 deg of level and the
    height within 1 m of the firmware's set point (the hold, then the landing's descent);
  - an experiment in progress stops with the rotor named; the vehicle holds, says it is
    landing, lands and disarms, without a crash.
A normal mission with noise, a k_f drift and a weak rotor (85 %) on random vehicles sees no
failure; nor do missions under link faults (lost, bursts of lost, duplicated, reordered and
delayed frames) on slow, late motors, where a failure is still found.
"""

import json
import random
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from octo_gcs.logs import Logs

from conftest import binary
from octo_gcs import campaign_spec
from test_sil_basic import random_vehicle

T_FAIL_HOVER = 15.0     # plant s: hold reached at about 6.3 s
T_FAIL_EXP = 12.0       # experiments excite from about 7.3 s to 17.3 s
T_FAIL_TAKEOFF = 3.0    # the take-off climbs through about 2.2 m at 1.4 m/s
DETECT_S = 0.5
TILT_DEG = 15.0
HEIGHT_M = 1.0


def fly(tmp_path, name, script, *args, exe="octo-sil"):
    d = tmp_path / name
    d.mkdir()
    argv = [str(binary(exe)), "--quiet", "--params", str(d / "p.parm"), "--lcm-fw", f"file://{d / 'fw.lcm'}",
            "--lcm-sim", f"file://{d / 'truth.lcm'}", "--script", script, *map(str, args)]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return Logs([d / "fw.lcm", d / "truth.lcm"])


def tilt_deg(q):
    x, y = q[:, 1], q[:, 2]
    return np.degrees(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)))


def survived(logs, j, t_fail, experiment=None, takeoff=False):
    """Checks one flight with rotor j (1-based) failed at t_fail; returns the measurements. In
    the take-off the set point climbs on after the detection (the height checked against it),
    and the take-off command is answered FAILED with the rotor named."""
    tr, fw, ev = logs.truth, logs.fw, logs.events
    texts = [s for _, _, s in ev]
    found = [(t, s) for t, _, s in ev if s.startswith("Rotor ") and " failed " in s]
    assert len(found) == 1, texts
    t_det, line = found[0]
    assert line.startswith(f"Rotor {j} failed (effectiveness 0.00"), line
    detect = t_det - t_fail
    assert 0.0 <= detect <= DETECT_S, (detect, line)
    if experiment is not None:
        assert f"ID aborted: rotor {j} failed" in texts, texts
    if takeoff:
        mode = [s for t, _, s in ev if s.startswith("Mode ") and t <= t_det]
        assert mode[-1] == "Mode TAKEOFF", mode
    assert "Rotor failure: landing" in texts and "Landed" in texts and texts[-1] == "Mode DISARMED", texts
    # the plant did cut it
    after = tr.t >= t_fail
    assert np.all(tr.rotor_scale[after, j - 1] == 0.0)
    # attitude and height from the failure to the touch-down (the firmware's heights are its
    # measured frame: the truth's plus the origin's altitude)
    t_land = [t for t, _, s in ev if s == "Landed"][-1]
    win = after & (tr.t <= t_land) & ~tr.on_ground
    assert win.sum() > 90
    # a landing, not a fall: the descent at most a little faster than the landing speed
    vz = float(-tr.vel_i[win, 2].min())
    assert vz < 1.5, vz
    tilt = float(tilt_deg(tr.q_i2b[win]).max())
    off = float(np.median(fw.pos_i[:, 2] - np.interp(fw.t, tr.t, tr.pos_i[:, 2])))
    z_sp = np.interp(tr.t[win], fw.t, fw.z_sp) - off
    dz = float(np.abs(tr.pos_i[win, 2] - z_sp).max())
    assert tilt < TILT_DEG, tilt
    assert dz < HEIGHT_M, dz
    # the hold on the remaining rotors (to the landing command): the height it held
    t_cmd = [t for t, _, s in ev if s == "Rotor failure: landing"][0]
    hold = after & (tr.t < t_cmd)
    if takeoff:
        dz_hold = float(np.abs(tr.pos_i[hold, 2] - np.interp(tr.t[hold], fw.t, fw.z_sp) + off).max())
    else:
        z0 = float(np.interp(t_fail, tr.t, tr.pos_i[:, 2]))
        dz_hold = float(np.abs(tr.pos_i[hold, 2] - z0).max())
    assert dz_hold < HEIGHT_M, dz_hold
    return detect, tilt, dz, dz_hold, vz


def hover_script():
    return "arm; takeoff 5; wait hold; sleep 20; wait disarmed"


def takeoff_script():
    # not `wait hold`: the take-off is answered FAILED at the detection
    return "arm; takeoff 5; sleep 25; wait disarmed"


def exp_script(e):
    # not `wait experiment`: the experiment ends FAILED (the rotor), which would end the script
    return f"arm; takeoff 5; wait hold; experiment {e}; sleep 25; wait disarmed"


@pytest.mark.parametrize("exe", ["octo-sil", "octo-sil-fixed"])
@pytest.mark.parametrize("j", range(1, 9))
def test_hover(tmp_path, exe, j):
    logs = fly(tmp_path, "f", hover_script(), "--fail-rotor", f"{j}@{T_FAIL_HOVER}", exe=exe)
    d, tilt, dz, dz_hold, vz = survived(logs, j, T_FAIL_HOVER)
    print(f"{exe} hover rotor {j}: detected after {d:.3f} s, tilt {tilt:.1f} deg, height to set point "
          f"{dz:.3f} m, in the hold {dz_hold:.3f} m, descent {vz:.2f} m/s")


@pytest.mark.parametrize("exe", ["octo-sil", "octo-sil-fixed"])
@pytest.mark.parametrize("j", range(1, 9))
def test_takeoff(tmp_path, exe, j):
    """Judged in the take-off once off the ground: a rotor lost in the climb is found, the take-off
    answered FAILED naming it, and the vehicle lands."""
    logs = fly(tmp_path, "f", takeoff_script(), "--fail-rotor", f"{j}@{T_FAIL_TAKEOFF}", exe=exe)
    d, tilt, dz, dz_hold, vz = survived(logs, j, T_FAIL_TAKEOFF, takeoff=True)
    print(f"{exe} take-off rotor {j}: detected after {d:.3f} s, tilt {tilt:.1f} deg, height to set point "
          f"{dz:.3f} m, in the hold {dz_hold:.3f} m, descent {vz:.2f} m/s")


def test_takeoff_step_fails_naming_the_rotor(tmp_path):
    """octo-sil's `wait hold` fails at once with the firmware's reason, as a campaign row gives it."""
    d = tmp_path / "f"
    d.mkdir()
    r = subprocess.run([str(binary("octo-sil")), "--quiet", "--params", str(d / "p.parm"), "--script",
                        "arm; takeoff 5; wait hold", "--fail-rotor", f"4@{T_FAIL_TAKEOFF}"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 1
    line = [x for x in r.stderr.splitlines() if "script step" in x]
    assert line and "'wait hold' failed at t=3.0" in line[0] and "Rotor 4 failed" in line[0], r.stderr


def test_not_judged_near_the_ground(tmp_path):
    """Below the take-off's level height (0.3 m) rotors are not judged: the spool-up and ground
    contact are there. A rotor lost at 0.5 s (about 0.18 m) is found only once the vehicle is
    above it, if it gets there; no line names a rotor before."""
    d = tmp_path / "f"
    d.mkdir()
    argv = [str(binary("octo-sil")), "--quiet", "--params", str(d / "p.parm"), "--lcm-fw", f"file://{d / 'fw.lcm'}",
            "--lcm-sim", f"file://{d / 'truth.lcm'}", "--script", "arm; takeoff 5; sleep 8", "--fail-rotor", "2@0.5"]
    subprocess.run(argv, capture_output=True, text=True, timeout=120)
    logs = Logs([d / "fw.lcm", d / "truth.lcm"])
    found = [t for t, _, s in logs.events if s.startswith("Rotor 2 failed")]
    tr = logs.truth
    for t in found:
        assert float(np.interp(t, tr.t, tr.pos_i[:, 2])) > 0.25, (t, found)


@pytest.mark.parametrize("e", [1, 3, 4, 5])
@pytest.mark.parametrize("j", range(1, 9))
def test_during_experiment(tmp_path, e, j):
    logs = fly(tmp_path, "f", exp_script(e), "--fail-rotor", f"{j}@{T_FAIL_EXP}")
    # the experiment was exciting when the rotor failed
    phases = logs.phases()
    assert phases and phases[0][1] + 1.0 < T_FAIL_EXP, phases
    d, tilt, dz, dz_hold, vz = survived(logs, j, T_FAIL_EXP, experiment=e)
    print(f"experiment {e} rotor {j}: detected after {d:.3f} s, tilt {tilt:.1f} deg, height to set point "
          f"{dz:.3f} m, in the hold {dz_hold:.3f} m, descent {vz:.2f} m/s")


@pytest.mark.parametrize("j", [3, 6])
def test_speed_alone(tmp_path, j):
    """Without the thrust rows the rotor speeds (ESC telemetry) find it."""
    logs = fly(tmp_path, "f", hover_script(), "--fail-rotor", f"{j}@{T_FAIL_HOVER}", "--sensors", "imu,rpm")
    survived(logs, j, T_FAIL_HOVER)
    assert any(f"Rotor {j} failed" in s and "from its speed" in s for _, _, s in logs.events)


def test_partial_failure_scale_learned(tmp_path):
    """A rotor left at 30 %: found, its MOT_SCALE set near 0.3, the vehicle still lands."""
    logs = fly(tmp_path, "f", hover_script(), "--fail-rotor", f"5@{T_FAIL_HOVER}:0.3")
    line = [s for _, _, s in logs.events if s.startswith("Rotor 5 failed")]
    assert line, [s for _, _, s in logs.events]
    s = float(line[0].split("effectiveness ")[1].split(",")[0])
    assert abs(s - 0.3) < 0.05, line
    assert "Landed" in [s for _, _, s in logs.events]


def noisy_vehicle(seed, weak=True):
    rng = random.Random(seed)
    v = random_vehicle(rng)
    hover = v["mass"] * 9.796 / 8
    v["noise"] = {"thrust": round(rng.uniform(0.01, 0.03) * hover, 4), "gyro": 0.01}
    v["kf_drift_per_min"] = -0.02
    if weak:
        sc = [1.0] * 8
        sc[rng.randrange(8)] = 0.85
        v["rotor_scale"] = sc
    return v


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_no_false_alarm(tmp_path, seed):
    """The whole identification sequence (experiment 6) on a random noisy vehicle with a weak
    rotor and a drifting k_f: no rotor is called failed."""
    v = noisy_vehicle(seed)
    path = tmp_path / "v.json"
    path.write_text(json.dumps(v))
    script = (f"param VEH_MASS {v['mass']}; param VEH_ARM_L {v['arm_length']}; param ID_MOT_TAU {v['motor_tau']}; "
              "arm; takeoff 5; wait hold; experiment 6; sleep 70; land; wait disarmed")
    logs = fly(tmp_path, "f", script, "--vehicle", path, "--seed", seed)
    texts = [s for _, _, s in logs.events]
    assert "ID done" in texts, texts
    assert not any(s.startswith("Rotor ") for s in texts), texts


@pytest.mark.parametrize("seed", [21, 22])
def test_random_vehicle_survives(tmp_path, seed):
    """The same noisy random vehicles lose a random rotor in hover."""
    v = noisy_vehicle(seed, weak=False)
    path = tmp_path / "v.json"
    path.write_text(json.dumps(v))
    j = random.Random(seed).randrange(1, 9)
    logs = fly(tmp_path, "f", hover_script(), "--vehicle", path, "--seed", seed, "--fail-rotor", f"{j}@{T_FAIL_HOVER}")
    survived(logs, j, T_FAIL_HOVER)


# Missions of the fault campaign (host_tools/campaigns/faults.json) on which a detector read a
# working rotor as failed: link delay of 2 frames on top of a 2-frame transport delay, bursts,
# lost, duplicated and reordered frames, slow motors.
CAMPAIGN = Path(__file__).resolve().parents[2] / "host_tools" / "campaigns" / "faults.json"
LINK_MISSIONS = [720, 770, 878]


def campaign_mission(index):
    """octo-sil's flags and steps for the campaign's mission `index` (its vehicle, faults and
    seed; the experiment followed by a sleep, so that a stopped experiment ends nothing)."""
    spec = campaign_spec.validate(json.loads(CAMPAIGN.read_text()))
    seed, _d, vehicle, faults, _params = campaign_spec.mission_inputs(spec, index)
    flags = [x for k, v in faults.items() for x in (f"--{k.replace('_', '-')}", v)]
    script = (f"param VEH_MASS {vehicle['mass']!r}; param VEH_ARM_L {vehicle['arm_length']!r}; param ID_SEED {seed}; "
              "arm; takeoff 10; wait hold; experiment 6; sleep 70; land; wait disarmed")
    return seed, vehicle, flags, script


@pytest.mark.parametrize("index", LINK_MISSIONS)
def test_link_faults_no_false_failure(tmp_path, index):
    """The campaign's missions with link faults and no rotor failure: none is named."""
    seed, vehicle, flags, script = campaign_mission(index)
    vehicle.pop("rotor_failure", None)
    path = tmp_path / "v.json"
    path.write_text(json.dumps(vehicle))
    d = tmp_path / "f"
    d.mkdir()
    argv = [str(binary("octo-sil")), "--quiet", "--params", str(d / "p.parm"), "--lcm-fw", f"file://{d / 'fw.lcm'}",
            "--vehicle", str(path), "--seed", str(seed), "--script", script, *map(str, flags)]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert "crashed" not in r.stderr, r.stderr
    withheld = re.search(r"(\d+) withheld by faults", r.stderr)
    assert withheld and int(withheld.group(1)) > 0, r.stderr[-400:]
    texts = [s for _, _, s in Logs([d / "fw.lcm"]).events]
    assert not any(s.startswith("Rotor ") for s in texts), [s for s in texts if s.startswith("Rotor")]


@pytest.mark.parametrize("seed", [31, 32, 33])
def test_link_bursts_slow_late_motor(tmp_path, seed):
    """Hover and the rotor experiment under bursts of lost frames (20 frames, often), lost,
    duplicated, reordered and 2-frame delayed frames, on a noisy random vehicle with a slow (80 ms),
    late (2 frames) motor: no rotor is named. Then the same with rotor j cut in the hover: found
    within 0.5 s, the right one."""
    v = noisy_vehicle(seed, weak=False)
    v["motor_tau"], v["delay"] = 0.08, 0.022222
    path = tmp_path / "v.json"
    path.write_text(json.dumps(v))
    link = ["--burst", 20, "--burst-prob", 0.005, "--drop", 0.03, "--duplicate", 0.05, "--reorder", 0.03,
            "--delay-frames", 2]
    script = (f"param VEH_MASS {v['mass']}; param VEH_ARM_L {v['arm_length']}; arm; takeoff 5; wait hold; "
              "sleep 10; experiment 1; sleep 30; land; wait disarmed")
    d = tmp_path / "ok"
    d.mkdir()
    argv = [str(binary("octo-sil")), "--quiet", "--params", str(d / "p.parm"), "--lcm-fw", f"file://{d / 'fw.lcm'}",
            "--vehicle", str(path), "--seed", str(seed), "--script", script, *map(str, link)]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert "crashed" not in r.stderr, r.stderr
    withheld = re.search(r"(\d+) withheld by faults", r.stderr)
    assert withheld and int(withheld.group(1)) > 100, r.stderr[-400:]
    texts = [s for _, _, s in Logs([d / "fw.lcm"]).events]
    assert not any(s.startswith("Rotor ") for s in texts), [s for s in texts if s.startswith("Rotor")]

    j = random.Random(seed).randrange(1, 9)
    d = tmp_path / "cut"
    d.mkdir()
    argv = [str(binary("octo-sil")), "--quiet", "--params", str(d / "p.parm"), "--lcm-fw", f"file://{d / 'fw.lcm'}",
            "--vehicle", str(path), "--seed", str(seed), "--script", hover_script(), "--fail-rotor",
            f"{j}@{T_FAIL_HOVER}", *map(str, link)]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert "crashed" not in r.stderr, r.stderr
    found = [(t, s) for t, _, s in Logs([d / "fw.lcm"]).events if s.startswith("Rotor ") and " failed " in s]
    assert len(found) == 1 and found[0][1].startswith(f"Rotor {j} failed"), found
    assert 0.0 <= found[0][0] - T_FAIL_HOVER <= DETECT_S, found


# Missions of the wide envelope (host_tools/campaigns/wide.json: no rotor fails) on which the
# detector named a working rotor failed: a weak rotor (0.8-0.9, its scale not identified yet)
# under thrust noise of up to 12 times the default, in the take-off, the hold or the
# experiments.
WIDE = Path(__file__).resolve().parents[2] / "host_tools" / "campaigns" / "wide.json"
WIDE_MISSIONS = [41, 141, 233, 299, 379, 397, 425]


@pytest.mark.parametrize("index", WIDE_MISSIONS)
def test_wide_noisy_weak_rotor_no_false_failure(tmp_path, index):
    """The wide envelope's missions with a noisy weak rotor: none is named, the sequence ends."""
    spec = campaign_spec.validate(json.loads(WIDE.read_text()))
    seed, _d, vehicle, _faults, _params = campaign_spec.mission_inputs(spec, index)
    print(f"wide.json mission {index}: seed {seed}, thrust noise {vehicle['noise']['thrust']:.3f} N, "
          f"rotor scales {vehicle['rotor_scale']}")
    path = tmp_path / "v.json"
    path.write_text(json.dumps(vehicle))
    d = tmp_path / "f"
    d.mkdir()
    script = (f"param VEH_MASS {vehicle['mass']!r}; param VEH_ARM_L {vehicle['arm_length']!r}; param ID_SEED {seed}; "
              "arm; takeoff 10; wait hold; experiment 6; wait experiment; land; wait disarmed")
    argv = [str(binary("octo-sil")), "--quiet", "--params", str(d / "p.parm"), "--lcm-fw", f"file://{d / 'fw.lcm'}",
            "--vehicle", str(path), "--seed", str(seed), "--script", script]
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert "crashed" not in r.stderr, r.stderr
    texts = [s for _, _, s in Logs([d / "fw.lcm"]).events]
    assert not any(s.startswith("Rotor ") for s in texts), [s for s in texts if s.startswith("Rotor")]
    assert "ID done" in texts, texts[-20:]
