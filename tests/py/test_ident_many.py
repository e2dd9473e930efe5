"""The motor model over many random vehicles, flown in octo-sil (one process, about 30 ms a
flight): the tests' ranges (motor lag 10-100 ms, delay 0-3 frames, thrust curve 0-0.5, one
rotor at 0.8-1.0, k_f, k_tau and inertia +/-30 %), none of it told to the firmware.

Nothing accepted is wrong: every accepted run has the delay exact, the lag within 5 %, the
curve within 0.02, every rotor's scale within 0.5 %, k_f and k_tau within 0.1 % or 4 of their
reported sds. And the vehicles are identified: over 3,000 such flights 1 was rejected (its
whiteness test) and none aborted, so more than 4 rejections or aborts in 200 fail (at a true
rate of 0.1 % that happens with probability 2e-6; a regression to the 3 % measured before
this round's two fixes, the lag grid's walk and the torque gain, fails it 71 % of the time, to
the 1.1 % between them only 7 %). The sharp test is the second: the slow, late, strong
vehicles that tipped over the experiments' tilt limit (the attitude loop's gain 1.6-1.8 times
the map's with VEH_KF 20), drawn on their own: 30 % of them aborted before, 1.0 % were not
identified with the torque gain (1,000 draws: 10, most of them still at the tilt limit), 0.6 %
are not now, with the oscillation guard (1,000 draws, seeds 10000-10999: 1 at the tilt limit,
5 rejected by the whiteness test, nothing accepted wrong). At most 3 of 40: by chance at
0.6 % with probability 1e-4, and at the old 30 % with probability 6e-4.

The seeds are new each run and printed; OCTO_MANY_SEED=N repeats a draw, OCTO_MANY_N=K flies K
vehicles in each of the two campaigns instead of 200 and 40 (the figures above: OCTO_MANY_N=1000
with OCTO_MANY_SEED 7000, 20000 and 40000, and 10000 for the slow ones; the bounds are then 1
in 50 and 1 in 100). OCTO_STALE_N=K flies K pairs in the stale lag prior's test instead of 12.
"""

import json
import math
import os
import random
import re
import subprocess

import pytest

from conftest import binary
from ident_helpers import false_alarm, fw_said
from test_ident_motor import motor_vehicle

LIGHT_SEEDS = 24
TOL = {"lag": 0.05, "curve": 0.02, "scale": 0.005, "k": 0.001, "k_sds": 4.0}


def fly(tmp, veh, seed, keep=False, first="", settle=""):
    """One rotor experiment of a vehicle; the firmware's parameters after it and its stderr.
    Every vehicle starts from the firmware's defaults, unless `keep` (the parameter file of
    the flight before); `first`: mission steps before arming; `settle`: steps in HOLD before
    the experiment."""
    (tmp / "v.json").write_text(json.dumps(veh))
    prm = tmp / "p.parm"
    if not keep:
        prm.unlink(missing_ok=True)
    r = subprocess.run([str(binary("octo-sil")), "--seed", str(seed), "--vehicle", str(tmp / "v.json"),
                        "--params", str(prm), "--duration", "600", "--mission",
                        f"param ID_CRV_EST 1; {first}arm; takeoff 5; wait hold; {settle}experiment 1; wait experiment"],
                       capture_output=True, text=True, timeout=60)
    p = {}
    for line in prm.read_text().splitlines() if prm.exists() else []:
        parts = line.split()
        if len(parts) == 2 and not line.startswith("#"):
            p[parts[0]] = float(parts[1])
    return p, r


def wrong(p, veh):
    """The accepted values outside the tolerances, by name.
    Where a tolerance sits near 3 sds of the estimate (the curve's 0.02 on a vehicle hovering
    at low throttle: sd up to 0.007; k_f's 0.1 % when it is extrapolated through the curve), a
    value within 4 of its reported sds passes too (3,000 flights: one curve at 3.2 sds)."""
    bad = []
    if p["ID_DELAY_FR"] != round(veh["delay"] * 90.0):
        bad.append("delay")
    if abs(p["ID_MOT_TAU"] / veh["motor_tau"] - 1.0) > TOL["lag"]:
        bad.append("lag")
    e = abs(p["MOT_CURVE"] - veh["thrust_curve"])
    if e > TOL["curve"] and e > TOL["k_sds"] * p["ID_CRV_SD"]:
        bad.append("curve")
    bad += [f"MOT_SCALE{j + 1}" for j in range(8)
            if abs(p[f"MOT_SCALE{j + 1}"] / veh["rotor_scale"][j] - 1.0) > TOL["scale"]]
    for name, sd, truth in (("VEH_KF", "ID_KF_SD", veh["kf"]), ("VEH_KTAU", "ID_KTAU_SD", veh["ktau"])):
        if not (abs(p[name] / truth - 1.0) < TOL["k"] or abs(p[name] - truth) < TOL["k_sds"] * p[sd]):
            bad.append(name)
    return bad


def kf_summary(kf):
    """k_f's relative errors and sds (pairs) in one line: rms error, median, 95th percentile and
    largest sd, rms of error / sd and how many lie beyond 3 sds."""
    if not kf:
        return "k_f: none accepted"
    z = [e / sd for e, sd in kf]
    sds = sorted(sd for _, sd in kf)
    return (f"k_f of {len(kf)} accepted: error {100 * math.sqrt(sum(e * e for e, _ in kf) / len(kf)):.3f} % rms, "
            f"sd {100 * sds[len(sds) // 2]:.3f} % median, {100 * sds[(95 * len(sds)) // 100]:.3f} % 95th pct "
            f"({100 * sds[-1]:.3f} % at most), error / sd "
            f"{math.sqrt(sum(x * x for x in z) / len(z)):.3f} rms, {sum(abs(x) > 3 for x in z)} beyond 3")


def campaign(tmp_path, n, draw, what):
    """n vehicles drawn by `draw`, each flown once; OCTO_MANY_FIRST: mission steps before
    arming (e.g. "param ID_SWP_THR 0; ", the rotor experiment without its sweep)."""
    seed0 = int(os.environ.get("OCTO_MANY_SEED", random.SystemRandom().randrange(1, 10**6)))
    first = os.environ.get("OCTO_MANY_FIRST", "")
    print(f"OCTO_MANY_SEED={seed0}: {n} {what}")
    failed, silent, kf = [], [], []
    for i in range(n):
        seed = seed0 + i
        veh = draw(random.Random(seed))
        p, r = fly(tmp_path, veh, seed, first=first)
        if not int(p.get("ID_RESULT", 0)) & 1:
            why = [ln for ln in r.stderr.splitlines() if "rejected" in ln or "aborted" in ln or "failed" in ln]
            failed.append((seed, why[-2:]))
            continue
        kf.append((p["VEH_KF"] / veh["kf"] - 1.0, p["ID_KF_SD"] / p["VEH_KF"]))
        bad = wrong(p, veh)
        if bad:
            silent.append((seed, bad, veh, {k: p[k] for k in ("VEH_KF", "ID_KF_SD", "ID_MOT_TAU", "ID_DELAY_FR",
                                                                 "MOT_CURVE")}))
    print(f"not identified {len(failed)}: {failed}")
    print(kf_summary(kf))
    return failed, silent


def test_many_random_vehicles_identified_and_never_wrong(tmp_path):
    n = int(os.environ.get("OCTO_MANY_N", 200))
    failed, silent = campaign(tmp_path, n, lambda rng: motor_vehicle(rng)[0], "random vehicles")
    assert not silent, silent           # accepted and wrong: the worst defect
    assert len(failed) <= max(4, n // 50), failed


def slow_late_strong(rng):
    veh, _ = motor_vehicle(rng)
    veh.update(kf=28.0269 * rng.uniform(1.2, 1.3), motor_tau=rng.uniform(0.075, 0.100), delay=3 / 90.0)
    return veh


def test_slow_late_strong_vehicles_do_not_tip_over(tmp_path):
    """Lag 75-100 ms, 3 frames late, k_f 1.2-1.3 x the paper's: 30 % of these aborted at the
    tilt limit before the torque demands took the throttle map's error at hover out; of the
    rest most did, their attitude loop oscillating from the take-off on, before the
    oscillation guard lowered ATT_WN_RP (module docstring)."""
    n = int(os.environ.get("OCTO_MANY_N", 40))
    failed, silent = campaign(tmp_path, n, slow_late_strong, "slow, late, strong vehicles")
    assert not silent, silent
    assert len(failed) <= max(3, n // 100), failed


def hover_throttle(veh):
    """The throttle at which the vehicle's rotors carry its weight (its thrust curve's inverse)."""
    c, w = veh["thrust_curve"], veh["mass"] * 9.80665 / (8 * veh["kf"])
    return (math.sqrt((1 - c) ** 2 + 4 * c * w) - (1 - c)) / (2 * c) if c > 1e-6 else w


def light_vehicle(rng, lag=None, delay=None):
    """A vehicle of motor_vehicle's ranges, its mass +/-30 % too, hovering at a throttle of 0.10
    or less: the thrust rows' sweep rises to 4 times its hover thrust (3 g above the weight),
    for a few frames, about a motor lag on the slower motors. `lag` (a range) and `delay` (s):
    the motor's instead of motor_vehicle's."""
    while True:
        veh, _ = motor_vehicle(rng)
        veh["mass"] = round(2.132 * rng.uniform(0.7, 1.3), 6)
        if lag:
            veh["motor_tau"] = rng.uniform(*lag)
        if delay is not None:
            veh["delay"] = delay
        if hover_throttle(veh) <= 0.10:
            return veh


def rms_bounds(n, z=4.5):
    """The rms of n unit normals lies within these with probability 1 - 2 Phi(-z) (chi-square's
    quantiles by Wilson-Hilferty: within 1 % at these z from n = 20 on)."""
    a = 2.0 / (9.0 * n)
    return tuple(max(0.0, 1.0 - a + s * z * math.sqrt(a)) ** 1.5 for s in (-1.0, 1.0))


def test_light_vehicles_kf_sd_is_honest_over_seeds(tmp_path):
    """k_f's sd per vehicle, judged over seeds, on light, strong vehicles (hover throttle at
    most 0.10): four random ones, each flown on LIGHT_SEEDS seeds, error / sd a unit normal
    over them: its rms within rms_bounds (4.5 sds of chi-square's own spread: 1e-5 apart for a
    calibrated sd, a few in 10,000 at the 1.06 measured over 670 such flights) for each vehicle and
    pooled. The first one's motor is 73-79 ms slow, 2.4-2.6 times the default prior (ID_MOT_TAU
    0.03), and on time: its second lag grid walks (motor_id_refine), the last grid narrows
    after it. A flight the whiteness test rejects (its designed false alarm, about 1 %) is left
    out, at most 2 of a vehicle's. OCTO_MANY_SEED=N repeats a draw. A sd optimistic by 1.6 on
    such vehicles fails the pooled bound at once (1.33 at n = 96)."""
    seed0 = int(os.environ.get("OCTO_MANY_SEED", random.SystemRandom().randrange(1, 10**6)))
    print(f"OCTO_MANY_SEED={seed0}")
    pooled, bad = [], []
    for i in range(4):
        veh = light_vehicle(random.Random(seed0 + i), **({"lag": (0.073, 0.079), "delay": 0.0} if i == 0 else {}))
        z, chance = [], []
        for s in range(LIGHT_SEEDS):
            seed = seed0 + 100 * i + s
            p, r = fly(tmp_path, veh, seed, first=f"param VEH_MASS {veh['mass']}; ")
            if not int(p.get("ID_RESULT", 0)) & 1:
                assert false_alarm(fw_said(r.stderr)), (seed, fw_said(r.stderr)[-6:])
                chance.append(seed)
                continue
            z.append((p["VEH_KF"] - veh["kf"]) / p["ID_KF_SD"])
        n = len(z)
        rms, (lo, hi) = math.sqrt(sum(x * x for x in z) / n), rms_bounds(n)
        print(f"hover {hover_throttle(veh):.3f}, lag {1000 * veh['motor_tau']:.0f} ms, delay "
              f"{round(90 * veh['delay'])}, curve {veh['thrust_curve']:.2f}: k_f's error / sd over {n} "
              f"seeds rms {rms:.2f} (within [{lo:.2f}, {hi:.2f}]), mean {sum(z) / n:+.2f}, at most "
              f"{max(map(abs, z)):.1f}; rejected {chance}")
        assert len(chance) <= 2, chance
        if not lo <= rms <= hi:
            bad.append((seed0 + i, veh, round(rms, 2)))
        pooled += z
    rms, (lo, hi) = math.sqrt(sum(x * x for x in pooled) / len(pooled)), rms_bounds(len(pooled))
    print(f"pooled: rms {rms:.3f} over {len(pooled)} (within [{lo:.2f}, {hi:.2f}])")
    assert not bad, bad
    assert lo <= rms <= hi


OSC_LINE = re.compile(r"^Attitude oscillation (\d+) deg/s: ATT_WN_RP ([0-9.]+) -> ([0-9.]+)$")


def test_an_oscillating_attitude_loop_is_detuned_and_identified(tmp_path):
    """ATT_WN_RP 12 (the default is 7) on a slow, late vehicle: its attitude loop oscillates
    from the take-off on (up to 200 deg/s rms). The guard lowers ATT_WN_RP by 15 % per
    detection and says so; the experiment is refused while the rates oscillate, then runs
    (after 10 s in HOLD: a large oscillation decays over several seconds), and its values
    are within the tolerances; the lowered gain is saved with them. Over 300 draws (seeds
    118900-119199) every one was detuned and identified. At ATT_WN_RP 10, 5 % of the draws
    oscillate too little in hover for the guard, and 2 % then tip past the experiment's
    tilt limit (the guard does not act in an experiment: the inertia's excites the rates).
    One flight of the four may meet the whiteness test's false alarm (its designed rate, about
    1 %, on these vehicles: seed 134982), as any flight may; it is still detuned as above."""
    seed0 = int(os.environ.get("OCTO_MANY_SEED", random.SystemRandom().randrange(1, 10**6)))
    print(f"OCTO_MANY_SEED={seed0}")
    chance = []
    for i in range(4):
        veh = slow_late_strong(random.Random(seed0 + i))
        p, r = fly(tmp_path, veh, seed0 + i, first="param ATT_WN_RP 12; ", settle="sleep 10; ")
        said = fw_said(r.stderr)
        steps = [OSC_LINE.match(t) for t in said if t.startswith("Attitude oscillation")]
        assert steps and all(steps), (seed0 + i, said[-8:])
        wn = 12.0
        for m in steps:   # each step 15 % down from the one before
            # the rms is above 12 deg/s; the line rounds it to whole degrees (12.3 says 12)
            assert float(m.group(1)) >= 12.0 and float(m.group(2)) == pytest.approx(wn, abs=0.006)
            wn = float(m.group(3))
            assert wn == pytest.approx(0.85 * float(m.group(2)), abs=0.006)
        assert p["ATT_WN_RP"] == pytest.approx(wn, abs=0.006)   # the line gives 2 decimals
        if not int(p.get("ID_RESULT", 0)) & 1 and false_alarm(said):
            chance.append(seed0 + i)
            continue
        assert int(p.get("ID_RESULT", 0)) & 1, (seed0 + i, said[-8:])
        assert not wrong(p, veh), (seed0 + i, wrong(p, veh))
    assert len(chance) <= 1, chance


def test_a_stable_vehicle_is_never_detuned(tmp_path):
    """Motors of 10-40 ms, at most one frame late, any k_f, curve and weak rotor of the
    tested ranges: their take-off transients decay, and the guard never fires."""
    seed0 = int(os.environ.get("OCTO_MANY_SEED", random.SystemRandom().randrange(1, 10**6)))
    print(f"OCTO_MANY_SEED={seed0}")
    fired = []
    for i in range(40):
        rng = random.Random(seed0 + i)
        veh = motor_vehicle(rng)[0]
        veh.update(motor_tau=rng.uniform(0.01, 0.04), delay=rng.choice((0.0, 1 / 90.0)))
        p, r = fly(tmp_path, veh, seed0 + i)
        said = [t for t in fw_said(r.stderr) if t.startswith("Attitude oscillation")]
        if said or p.get("ATT_WN_RP", 7.0) != 7.0:
            fired.append((seed0 + i, said))
    assert not fired, fired


def said_of(r):
    """The firmware's "ID ..." lines of a flight."""
    return [t for t in fw_said(r.stderr) if t.startswith("ID ")]


def test_a_stale_lag_prior_is_named_and_its_remedy_works(tmp_path):
    """A parameter file from another vehicle (a motor swap, a second airframe): vehicle A's
    identified lag (70-100 ms) is the prior of vehicle B's experiment (10-20 ms). The lag grids
    start at the prior and walk at most a factor of about 5; B's lag can lie beyond. Then the
    rejection names that ("motor lag past the prior's reach", not the lag's 0.5-500 ms range,
    as before) and the remedy gives the lag found: flown again from it, B is identified, within
    the tolerances. Whatever B accepts at once is within them too, k_f included: from a prior
    6x off the second grid's minimum lies beyond it, and the third stage narrows the last
    grid to 1.08 (without it the last grid stayed at 1.26, whose interpolation put k_f up to
    2.5 % off with a sd of 0.4 %; bench item 5's stale-prior row)."""
    seed0 = int(os.environ.get("OCTO_MANY_SEED", random.SystemRandom().randrange(1, 10**6)))
    n = int(os.environ.get("OCTO_STALE_N", 12))
    print(f"OCTO_MANY_SEED={seed0}")
    reached, kf = 0, []
    for i in range(n):
        seed = seed0 + i
        rng = random.Random(seed)
        a, b = motor_vehicle(rng)[0], motor_vehicle(rng)[0]
        a["motor_tau"], b["motor_tau"] = rng.uniform(0.07, 0.1), rng.uniform(0.01, 0.02)
        fly(tmp_path, a, seed)
        p, r = fly(tmp_path, b, seed + 1, keep=True)
        if int(p.get("ID_RESULT", 0)) & 1:
            kf.append((p["VEH_KF"] / b["kf"] - 1.0, p["ID_KF_SD"] / b["kf"]))
            assert not wrong(p, b), (seed, wrong(p, b))
            continue
        said = said_of(r)
        if "ID rejected: motor lag past the prior's reach" not in said:
            continue   # rejected for another cause (a rotor's NE, whiteness): nothing applied
        m = re.search(r"^ID remedy: ID_MOT_TAU ([0-9.]+) \(the lag found\), fly again$", "\n".join(said), re.M)
        assert m, (seed, said)
        reached += 1
        p, r = fly(tmp_path, b, seed + 2, keep=True, first=f"param ID_MOT_TAU {m.group(1)}; ")
        if not int(p.get("ID_RESULT", 0)) & 1 and false_alarm(said_of(r)):   # its known rate
            p, r = fly(tmp_path, b, seed + 3, keep=True, first=f"param ID_MOT_TAU {m.group(1)}; ")
        assert int(p.get("ID_RESULT", 0)) & 1, (seed, said_of(r)[-6:])
        assert not wrong(p, b), (seed, wrong(p, b))
    print(f"{reached} of {n} past the prior's reach, identified on the second flight; accepted at once: "
          + kf_summary(kf))
