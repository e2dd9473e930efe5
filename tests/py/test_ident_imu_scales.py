"""Each rotor's effectiveness from the IMU and the rotor speeds (ID_SOURCE imu_rpm, what auto
takes when the ESCs' speeds are served; firmware/core/imu_scale.h): rotors weaker than
MOT_SCALE says, unknown to the firmware, are identified rather than rejected.

- A rotor at 0.78 that the firmware takes as 1: its scale comes out within max(3 sd, 1 %),
  it is named degraded, MOT_SCALE3 is applied (the parameter file), and k_f, I_x, I_y and
  k_tau / I_z are accepted and right (they rest on the identified scales). The fixed-point
  build too.
- A motor that turns slower at the same throttle: its scale is the speeds' share.
- Random vehicles of the tests' ranges (lag 10-100 ms, delay 0-3 frames, curve 0-0.5, k_f,
  k_tau and inertia +/-30 %) with one or two rotors at 0.8-1.0 unknown to the firmware: every
  scale within max(3 sd, 1 %) of the truth (over its median, as the firmware normalises), the
  scales' error / sd rms below 1.4 over the bulk (a unit normal's 100-sample rms passes 1.4
  with probability below 1e-6), at most one accepted value beyond max(3 sd, tolerance) in
  all, at most one run in ten not identified.

OCTO_IMU_SEED=N repeats a draw; OCTO_IMU_N=K flies K random vehicles (default 16).
"""

import math
import os
import random
import re

from test_ident_imu import PAPER, fly, imu_vehicle, judge, results

SCALE = re.compile(r"^ID scale (1-4|5-8) ([-0-9.]+) ([-0-9.]+) ([-0-9.]+) ([-0-9.]+)$")
SCALE_SD = re.compile(r"^ID scale sd (1-4|5-8) ([-0-9.]+) ([-0-9.]+) ([-0-9.]+) ([-0-9.]+)$")


def scales(said):
    """(the 8 scales, their sds) of the status lines, or None."""
    v, sd = {}, {}
    for ln in said:
        for rx, out in ((SCALE, v), (SCALE_SD, sd)):
            m = rx.match(ln)
            if m:
                out[m.group(1)] = [float(m.group(i)) for i in range(2, 6)]
    if len(v) < 2 or len(sd) < 2:
        return None
    return v["1-4"] + v["5-8"], sd["1-4"] + sd["5-8"]


def truth_scales(veh):
    s = veh.get("rotor_scale", [1.0] * 8)
    m = sorted(s)
    med = 0.5 * (m[3] + m[4])
    return [x / med for x in s]


def judge_scales(said, veh):
    """(z of each scale, those beyond max(3 sd, 1 %)), or None when no scales were said."""
    got = scales(said)
    if got is None:
        return None
    zs, wrong = [], []
    for j, (v, sd, t) in enumerate(zip(*got, truth_scales(veh))):
        zs.append((v - t) / sd if sd > 0 else math.inf)
        if abs(v - t) > max(3.0 * sd, 0.01):
            wrong.append((j + 1, v, sd, t))
    return zs, wrong


def weak_vehicle(rng):
    veh = imu_vehicle(rng)
    s = [1.0] * 8
    for j in rng.sample(range(8), rng.choice((1, 2))):
        s[j] = rng.uniform(0.8, 1.0)
    return dict(veh, rotor_scale=s)


def test_a_weak_rotor_is_identified_and_applied(tmp_path):
    veh = dict(PAPER, rotor_scale=[1, 1, 0.78, 1, 1, 1, 1, 1])
    for program in ("octo-sil", "octo-sil-fixed"):
        r, said = fly(tmp_path, veh, 14, program=program)
        assert r.returncode == 0, r.stderr[-3000:]
        assert "ID source imu_rpm: accelerometer, mass, throttles, rotor speeds" in said, said
        zs, wrong = judge_scales(said, veh)
        assert not wrong, (program, wrong, zs)
        assert any(ln.startswith("ID rotor 3 degraded: effectiveness 0.7") for ln in said), said
        assert not any("effectiveness is not MOT_SCALE" in ln for ln in said), said
        prm = (tmp_path / "p.parm").read_text()
        m = re.search(r"^MOT_SCALE3\s*[ ,=]\s*([-0-9.eE]+)", prm, re.MULTILINE)
        assert m and abs(float(m.group(1)) - 0.78) < 0.01, prm
        res = results(said)
        assert all(res[k][2] for k in ("kf", "ixx", "iyy", "ratio")), (program, res)
        z, bad = judge(res, veh)
        assert not bad, (program, bad, z)


def test_a_slow_motor_is_its_speeds_share(tmp_path):
    """A motor that turns slower at the same throttle (its thrust 0.85 from the start, through
    its speed): the thrust per w^2 is the others', the speed model's share makes the scale."""
    veh = dict(PAPER, rotor_failure={"rotor": 3, "at_s": 0, "scale": 0.85})
    _, said = fly(tmp_path, veh, 17, script="arm; takeoff 5; wait hold; experiment 1; wait experiment")
    zs, wrong = judge_scales(said, dict(veh, rotor_scale=[1, 1, 0.85, 1, 1, 1, 1, 1]))
    assert not wrong, (wrong, zs)
    assert results(said)["kf"][2], said


def test_random_weak_rotors_identified_against_truth_and_sd(tmp_path):
    n = int(os.environ.get("OCTO_IMU_N", "16"))
    seed0 = int(os.environ.get("OCTO_IMU_SEED", str(random.SystemRandom().randrange(1, 10**6))))
    print(f"OCTO_IMU_SEED={seed0}: {n} random vehicles, one or two weak rotors unknown")
    zs, wrong, failed, no_scales = [], [], [], []
    for i in range(n):
        seed = seed0 + i
        veh = weak_vehicle(random.Random(seed))
        _, said = fly(tmp_path, veh, seed)
        res = results(said)
        if not res.get("kf", (0, 0, False))[2]:
            failed.append((seed, [ln for ln in said if "rejected" in ln or "aborted" in ln][-2:]))
            continue
        js = judge_scales(said, veh)
        if js is None:
            no_scales.append((seed, [ln for ln in said if ln.startswith("ID scales")]))
        else:
            zs += js[0]
            wrong += [(seed, "scale", w) for w in js[1]]
        wrong += [(seed, w) for w in judge(res, veh)[1]]
    bulk = [z for z in zs if abs(z) <= 4.0]
    rms = math.sqrt(sum(z * z for z in bulk) / max(1, len(bulk)))
    print("scales' error / sd rms within 4:", rms, "of", len(zs), "\nnot identified:", failed,
          "\nscales not said:", no_scales, "\nwrong:", wrong)
    assert len(wrong) <= 1, wrong
    assert len(failed) + len(no_scales) <= max(1, n // 10), (failed, no_scales)
    assert rms < 1.4, rms
