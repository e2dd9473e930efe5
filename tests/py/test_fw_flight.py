"""octo-fw flies octo-sim in lockstep: take-off, hold, land, frame loss, link loss.

Height and tilt are judged on octo-sim's ground truth (LCM log, simulated time)
with octo-fw's nominal, deliberately wrong vehicle parameters (VEH_KF 20 N for
28.03 N, VEH_KTAU 0.3 for 0.387 N m, inertia 0.05 for 0.063/0.076/0.101).
"""

import pytest

from test_fw_rig import Rig, mavlink, read_log, tilt_deg, wait_exit

TAKEOFF_M = 10.0
HOLD_S = 30.0


def fly_and_hold(rig, sim_args=(), duration=100.0):
    rig.start(sim_args=["--duration", duration, *sim_args])
    rig.arm_when_ready()
    r, texts = rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, TAKEOFF_M)
    assert r == mavlink.MAV_RESULT_ACCEPTED, texts
    wait_exit(rig.sim, timeout=120)
    rig.fw.stop()
    events = read_log(rig.fw_log, "OCTO_FW_EVENT")
    holds = [e.utime * 1e-6 for e in events if e.text == "Mode HOLD"]
    takeoffs = [e.utime * 1e-6 for e in events if e.text == "Mode TAKEOFF"]
    assert holds and takeoffs, [e.text for e in events]
    truth = read_log(rig.truth_log, "OCTO_TRUTH")
    assert truth, "no truth log"
    z0 = truth[0].pos_i[2]
    t_hold = holds[0]
    window = [s for s in truth if t_hold <= s.t <= t_hold + HOLD_S]
    assert window and window[-1].t >= t_hold + HOLD_S - 0.1, \
        f"hold from {t_hold:.2f} s not covered by the truth log (ends {truth[-1].t:.2f} s)"
    dz = [s.pos_i[2] - z0 - TAKEOFF_M for s in window]
    tilt = [tilt_deg(s.q_i2b) for s in window]
    print(f"hold from {t_hold:.2f} s: |dz| <= {max(map(abs, dz)):.4f} m, tilt <= {max(tilt):.3f} deg")
    return t_hold - takeoffs[0], dz, tilt


def check_fw_log(rig):
    """The firmware log: one record per frame, stamped with plant time, consistent."""
    frames = read_log(rig.fw_log, "OCTO_FW_FRAME")
    assert len(frames) > 1000
    ts = [f.t for f in frames]
    assert all(b >= a for a, b in zip(ts, ts[1:]))
    assert all(f.utime == round(f.t * 1e6) for f in frames)
    flying = [f for f in frames if f.stepped and f.mode in (2, 3)]
    assert flying
    for f in flying:
        assert all(0.0 <= t <= 1.0 for t in f.throttle)
        assert abs(sum(f.rotor_f) - f.f_alloc) < 1e-2 * max(1.0, f.f_alloc)
        assert abs(f.f_alloc - f.f_dem) < 1e-2 * f.f_dem        # nothing saturated in a hover
        assert 0.0 < f.dt < 0.25
        assert f.kf == pytest.approx(20.0) and f.inertia[0] == pytest.approx(0.05)
    # the allocation is the paper's open loop: T_j = f_j / k_f
    f = flying[-1]
    assert all(abs(t - fj / f.kf) < 1e-4 for t, fj in zip(f.throttle, f.rotor_f))


@pytest.mark.parametrize("version", [11, 12])
@pytest.mark.parametrize("actuation", ["dref", "data25"])
def test_takeoff_and_hold_with_wrong_nominal_parameters(launch, port, tmp_path, version, actuation):
    rig = Rig(launch, port, tmp_path, version=version, actuation=actuation)
    t_hold, dz, tilt = fly_and_hold(rig)
    assert t_hold < 20.0, f"took {t_hold:.1f} s from take-off to the hold"
    assert max(abs(d) for d in dz) <= 0.1, f"height error up to {max(dz, key=abs):+.3f} m"
    assert max(tilt) <= 1.0, f"tilt up to {max(tilt):.2f} deg"
    check_fw_log(rig)


def test_hold_with_20_percent_frames_dropped(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    # octo-sim's lockstep does not wait for an answer to a frame it dropped
    t_hold, dz, tilt = fly_and_hold(rig, sim_args=["--drop", 0.2])
    assert max(abs(d) for d in dz) <= 0.5, f"height error up to {max(dz, key=abs):+.3f} m"
    assert max(tilt) <= 5.0


def test_land_disarms_on_touchdown(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    rig.start()
    rig.arm_when_ready()
    r, _ = rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 3.0)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    # the take-off has begun (the status line comes with the answer)
    for _ in range(20):
        if "Mode TAKEOFF" in rig.texts:
            break
        rig.recv({"NONE"}, timeout=0.05)
    assert "Mode TAKEOFF" in rig.texts, rig.texts
    # retries of the same take-off are idempotent
    r, _ = rig.cmd(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 3.0, confirmation=1)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    # wait for the hold, then land
    deadline_ok = False
    for _ in range(100):
        if "Mode HOLD" in rig.texts:
            deadline_ok = True
            break
        rig.recv({"NONE"}, timeout=0.05)
    assert deadline_ok, rig.texts
    r, _ = rig.cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    assert r == mavlink.MAV_RESULT_TEMPORARILY_REJECTED   # flying: no disarm without force
    r, _ = rig.cmd(mavlink.MAV_CMD_NAV_LAND)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    for _ in range(200):
        if "Mode DISARMED" in rig.texts:
            break
        rig.recv({"NONE"}, timeout=0.05)
    assert "Landed" in rig.texts and "Mode DISARMED" in rig.texts, "|".join(rig.texts)
    hb = rig.recv({"HEARTBEAT"}, timeout=2)
    assert hb is not None and not (hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)


def test_link_loss_is_reported_and_long_loss_lands_on_recovery(launch, port, tmp_path):
    import time
    rig = Rig(launch, port, tmp_path)
    rig.start()
    rig.takeoff_and_hold(3.0)
    rig.sim.stop()                      # X-Plane gone
    t_kill = time.monotonic()
    while not any("link lost" in t for t in rig.texts) and time.monotonic() - t_kill < 3:
        rig.recv(set(), timeout=0.05)
    lost_after = time.monotonic() - t_kill
    assert any("link lost" in t for t in rig.texts), rig.texts
    assert lost_after < 1.0
    hb = rig.recv({"HEARTBEAT"}, timeout=2)
    assert hb.system_status == mavlink.MAV_STATE_CRITICAL
    rig.recv(set(), timeout=max(0.0, 2.5 - (time.monotonic() - t_kill)))
    rig.version = 11                    # X-Plane back: a fresh one, another version even
    rig.truth_log = tmp_path / "truth2.lcm"
    rig.start_sim()
    deadline = time.monotonic() + 15
    while "Mode DISARMED" not in rig.texts and time.monotonic() < deadline:
        rig.recv(set(), timeout=0.05)
    assert any("link back" in t for t in rig.texts), rig.texts
    assert "Mode LAND" in rig.texts and "Mode DISARMED" in rig.texts, "|".join(rig.texts)
    rig.sim.stop()
    truth = read_log(rig.truth_log, "OCTO_TRUTH")
    assert truth and max(tilt_deg(s.q_i2b) for s in truth) < 5.0


FAULTS = "--duplicate 0.1 --reorder 0.1 --delay-frames 2"


def test_hold_with_duplicated_reordered_and_delayed_frames(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    t_hold, dz, tilt = fly_and_hold(rig, sim_args=FAULTS.split())
    assert max(abs(d) for d in dz) <= 0.5, f"height error up to {max(dz, key=abs):+.3f} m"
    assert max(tilt) <= 5.0
