"""A flyable vehicle whose k_f is far from VEH_KF holds still, in both builds (octo-sil and
octo-sil-fixed). Random vehicles (mass 1-5 kg, hover throttle 0.06-0.4, the paper's k_tau / k_f
and inertia), VEH_KTAU scaled with VEH_KF (the rotors misjudged alike), the mass told:
- weak: true k_f 0.1-0.3x VEH_KF. The torques reach the rotors through VEH_KF, so every torque
  the attitude loop asks for comes out 3-10 times weaker; the attitude loop's damping drops
  with the square root of that, and the loop, its integral and the position loop around it
  oscillate at a growing amplitude (about 0.4 Hz). The oscillation guard's lower ATT_WN_RP
  only moves the attitude loop closer to the other two, and the vehicle crashes (5 of these
  8 without the allocation below, and one more oscillated).
- strong: true k_f 3-5x VEH_KF, with slow motors (60-80 ms, two frames of delay): the torques
  come out 3-5 times stronger, which a torque gain held to 0.5 or more left at 1.5-2.5 times
  what the loop is tuned for (one of 8 oscillated, one more at three times the rate rms).
The firmware scales the torques by what hover learning finds (env_hover_torque_scale: the weak
vehicles' torques by half of VEH_KF over the learned k_f, a curve's secant allowed for, so
they stay up to twice too weak, which flies; the strong ones' by all of it) and says so at
HOLD entry.

Every second flight the plant serves the IMU alone (hover learned from the accelerometer).
Each flight: take-off to 5 m, 60 s of HOLD. Asserted: HOLD reached, the hover k_f within 2 % of
the truth, the allocation line naming it, no oscillation line, and over the 60 s the tilt
below 3 degrees, the roll and pitch rates' rms below 3 deg/s (a steady hold shows 0.5) and the
height within 0.1 m of its set point (the collective's hover thrust is 8 VEH_KF u_h, learned:
it holds within 6 cm).
"""

import json
import math
import random
import re
import subprocess

import pytest

from conftest import binary
from test_fw_rig import read_log, tilt_deg

G = 9.796
HOLD_S = 60.0
KTAU_PER_KF = 0.3869 / 28.0269


def draw(rng, lo, hi, slow):
    """A vehicle and VEH_KF such that its true k_f is lo-hi times VEH_KF; `slow`: motor lag
    60-80 ms and two frames of delay (default: 30 ms, none)."""
    mass = rng.uniform(1.0, 5.0)
    u_h = rng.uniform(0.06, 0.4)
    kf = mass * G / (8 * u_h)
    veh_kf = kf / rng.uniform(lo, hi)
    veh = {"mass": mass, "kf": kf, "ktau": KTAU_PER_KF * kf}
    if slow:
        veh.update(motor_tau=rng.uniform(0.06, 0.08), delay=2 / 90)
    return veh, veh_kf


def fly(tmp, build, veh, veh_kf, seed, imu_only):
    """Take-off and 60 s of HOLD; the firmware's console and its log's HOLD frames.
    imu_only: the plant serves the IMU alone (hover learned from the accelerometer)."""
    (tmp / "v.json").write_text(json.dumps(veh))
    prm, log = tmp / "p.parm", tmp / "fw.lcm"
    prm.write_text(f"VEH_MASS {veh['mass']:.6g}\nVEH_KF {veh_kf:.6g}\nVEH_KTAU {KTAU_PER_KF * veh_kf:.6g}\n")
    log.unlink(missing_ok=True)
    r = subprocess.run([str(binary(build)), "--seed", str(seed), "--vehicle", str(tmp / "v.json"),
                        "--params", str(prm), "--duration", "150", "--lcm-fw", f"file://{log}",
                        "--script", f"arm; takeoff 5; wait hold; sleep {HOLD_S:g}"]
                       + (["--sensors", "imu"] if imu_only else []),
                       capture_output=True, text=True, timeout=120)
    frames = [f for f in read_log(log, "OCTO_FW_FRAME") if f.stepped and f.mode == 3] if log.exists() else []
    return r, frames


@pytest.mark.parametrize("build", ["octo-sil", "octo-sil-fixed"])
@pytest.mark.parametrize("side,lo,hi", [("weak", 0.1, 0.3), ("strong", 3.0, 5.0)])
def test_far_kf_holds_still(tmp_path, build, side, lo, hi):
    bad = []
    for i in range(8):
        seed = 3200 + 10 * i + (0 if side == "weak" else 5)
        veh, veh_kf = draw(random.Random(seed), lo, hi, side == "strong")
        r, frames = fly(tmp_path, build, veh, veh_kf, seed, i % 2 == 1)
        said = r.stderr.splitlines()
        what = f"seed {seed}{' imu' * (i % 2)}: k_f {veh['kf']:.2f} N ({veh['kf'] / veh_kf:.2f} of VEH_KF {veh_kf:.3g}), mass {veh['mass']:.2f} kg"
        hover = [ln for ln in said if "Hover throttle" in ln]
        alloc = [ln for ln in said if re.search(r"of VEH_KF [0-9.]+: torques x[0-9.]+$", ln)]
        osc = [ln for ln in said if "Attitude oscillation" in ln]
        if r.returncode != 0 or not hover or len(frames) < HOLD_S * 85:
            bad.append(f"{what}: no 60 s hold: {[ln[:120] for ln in said[-3:-1]]}")
            continue
        kf = float(hover[0].split("k_f ")[1].split("+/-")[0])
        tilt = max(tilt_deg(f.q) for f in frames)
        rms = math.degrees(math.sqrt(sum(f.rate_b[0] ** 2 + f.rate_b[1] ** 2 for f in frames) / len(frames)))
        dz = max(abs(f.pos_i[2] - f.z_sp) for f in frames)
        print(f"{build} {what}: hover k_f {kf:.3f}, tilt {tilt:.2f} deg, rate rms {rms:.2f} deg/s, height {dz:.3f} m off, {alloc}")
        if abs(kf / veh["kf"] - 1.0) > 0.02 or not alloc or osc or tilt > 3.0 or rms > 3.0 or dz > 0.1:
            bad.append(f"{what}: hover k_f {kf:.3f}, tilt {tilt:.1f} deg, rms {rms:.1f} deg/s, dz {dz:.2f} m, {alloc} {osc[:2]}")
    assert not bad, "\n".join(bad)
