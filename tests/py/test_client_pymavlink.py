"""What a pymavlink-based ground station (the octo dialect) reads from octo-fw: standard
modes, a heartbeat that pymavlink does not read with ArduPilot's tables, sensor health,
no fence breach, unknown battery, home on request, telemetry intervals. Every wait has
a deadline."""

import math
import time

import pytest

from octo_gcs import link
from pymavlink import mavutil
from test_fw_rig import Rig

M = link.mavlink
ARDUCOPTER = set(mavutil.mode_mapping_acm.values())


@pytest.fixture
def rig(launch, port, tmp_path):
    r = Rig(launch, port, tmp_path)
    r.start_sim(lockstep=False)
    r.start_fw()
    r.connect()
    return r


def request(rig, msgid, name, param2=0, n=1, timeout=3.0):
    rig.m.mav.command_long_send(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, msgid, param2, 0, 0, 0, 0, 0)
    got, deadline = [], time.monotonic() + timeout
    while len(got) < n and time.monotonic() < deadline:
        msg = rig.recv({name}, timeout=deadline - time.monotonic())
        if msg is not None:
            got.append(msg)
    return got


def test_standard_modes_heartbeat_health_home_and_intervals(rig):
    # standard modes: six modes, by name; take-off, hold and land are MAVLink's
    modes = request(rig, M.MAVLINK_MSG_ID_AVAILABLE_MODES, "AVAILABLE_MODES", n=6)
    assert len(modes) == 6
    by_custom = {m.custom_mode: m for m in modes}
    assert {k: v.mode_name for k, v in by_custom.items()} == link.MODES
    assert all(m.number_modes == 6 for m in modes)
    assert sorted(m.mode_index for m in modes) == [1, 2, 3, 4, 5, 6]
    assert by_custom[2].standard_mode == M.MAV_STANDARD_MODE_TAKEOFF
    assert by_custom[3].standard_mode == M.MAV_STANDARD_MODE_POSITION_HOLD
    assert by_custom[5].standard_mode == M.MAV_STANDARD_MODE_LAND
    assert all(m.properties & M.MAV_MODE_PROPERTY_NOT_USER_SELECTABLE for m in modes)
    one = request(rig, M.MAVLINK_MSG_ID_AVAILABLE_MODES, "AVAILABLE_MODES", param2=4)
    assert len(one) == 1 and one[0].mode_index == 4
    cur = rig.recv({"CURRENT_MODE"}, timeout=3)
    assert cur is not None and (cur.custom_mode, cur.standard_mode) == (0, M.MAV_STANDARD_MODE_NON_STANDARD)

    # heartbeat: custom_mode is octo-fw's mode, not read with ArduCopter's table
    hb = rig.recv({"HEARTBEAT"}, timeout=3)
    assert hb.custom_mode == 0 and not hb.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert mavutil.mode_string_v10(hb) not in ARDUCOPTER

    # health once frames flow; the fence is not present and not breached; battery unknown
    deadline, st = time.monotonic() + 10, None
    need = (M.MAV_SYS_STATUS_SENSOR_3D_GYRO | M.MAV_SYS_STATUS_SENSOR_3D_ACCEL |
            M.MAV_SYS_STATUS_SENSOR_GPS | M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | M.MAV_SYS_STATUS_PREARM_CHECK)
    while time.monotonic() < deadline:
        st = rig.recv({"SYS_STATUS"}, timeout=2)
        if st is not None and st.onboard_control_sensors_health & need == need:
            break
    assert st is not None and st.onboard_control_sensors_health & need == need, st
    assert st.onboard_control_sensors_present & need == need
    assert st.onboard_control_sensors_enabled & need == need
    fence = M.MAV_SYS_STATUS_GEOFENCE
    assert not st.onboard_control_sensors_present & fence and st.onboard_control_sensors_health & fence
    assert (st.voltage_battery, st.current_battery, st.battery_remaining) == (65535, -1, -1)
    bat = rig.recv({"BATTERY_STATUS"}, timeout=3)
    assert bat is not None and bat.voltages[0] == 65535 and bat.battery_remaining == -1

    # home on GET_HOME_POSITION and REQUEST_MESSAGE, where GLOBAL_POSITION_INT says
    r, _ = rig.cmd(M.MAV_CMD_GET_HOME_POSITION)
    assert r == M.MAV_RESULT_ACCEPTED
    (home,) = request(rig, M.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION")
    gp = rig.recv({"GLOBAL_POSITION_INT"}, timeout=3)
    assert abs(home.latitude - gp.lat) < 20 and abs(home.longitude - gp.lon) < 20   # 1e-7 deg
    assert abs(home.altitude - gp.alt) < 100 and abs(gp.relative_alt) < 100         # mm
    assert gp.lat == pytest.approx(-23.21e7, abs=2e3) and gp.alt == pytest.approx(640e3, abs=300)
    gps = rig.recv({"GPS_RAW_INT"}, timeout=3)
    assert gps.fix_type == M.GPS_FIX_TYPE_3D_FIX and gps.satellites_visible == 255
    att = rig.recv({"ATTITUDE"}, timeout=3)
    assert abs(att.roll) < 0.05 and abs(att.pitch) < 0.05 and math.isfinite(att.yaw)
    ext = rig.recv({"EXTENDED_SYS_STATE"}, timeout=3)
    assert ext.landed_state == M.MAV_LANDED_STATE_ON_GROUND

    # intervals of the ground-station telemetry (MAVSDK sets EXTENDED_SYS_STATE's)
    ok, unknown = M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_UNSUPPORTED
    assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 200000)[0] == ok
    assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, -1)[0] == ok
    assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                   float("nan"))[0] == M.MAV_RESULT_DENIED
    assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 100000)[0] == unknown
    assert rig.cmd(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_AVAILABLE_MODES, 7)[0] == M.MAV_RESULT_DENIED


def local_positions(rig, seconds):
    """LOCAL_POSITION_NED messages for `seconds` of wall time."""
    out, deadline = [], time.monotonic() + seconds
    while time.monotonic() < deadline:
        msg = rig.recv({"LOCAL_POSITION_NED"}, timeout=deadline - time.monotonic())
        if msg is not None:
            out.append(msg)
    return out


def test_local_position_ned_from_the_local_origin_in_a_hover_and_across_an_origin_shift(launch, port, tmp_path):
    """LOCAL_POSITION_NED as PX4 and ArduPilot give it: from the local origin set on the ground
    at the first position, so z is -10 in a 10 m hover (the truth log's height above the
    take-off point), home is at the origin, relative_alt agrees with z; the plant's origin shift
    (real time, plant second 30) leaves no step in it."""
    from test_fw_rig import read_log
    r = Rig(launch, port, tmp_path)
    r.start_sim("--shift-origin", "30", lockstep=False)
    r.start_fw()
    r.connect()
    first = local_positions(r, 1.0)
    assert first and all(abs(m.z) < 0.1 and math.hypot(m.x, m.y) < 0.1 for m in first), first[:3]
    r.takeoff_and_hold(10.0, timeout=30.0)
    time.sleep(2.0)
    before = local_positions(r, 2.0)
    home = request(r, M.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION")[0]
    assert abs(home.x) < 0.1 and abs(home.y) < 0.1 and abs(home.z) < 0.1, home
    gp = r.recv({"GLOBAL_POSITION_INT"}, timeout=2)
    deadline = time.monotonic() + 40.0
    while not any(t.startswith("Plant moved its local origin") for t in r.texts):
        assert time.monotonic() < deadline, r.texts[-10:]
        r.recv(set(), timeout=0.1)
    across = local_positions(r, 3.0)
    r.sim.stop()
    r.fw.stop()
    truth = read_log(r.truth_log, "OCTO_TRUTH")
    z0 = truth[0].pos_i[2]
    hover = [t.pos_i[2] - z0 for t in truth if t.t > truth[-1].t - 12.0]
    assert min(hover) > 9.7 and max(hover) < 10.3   # the truth hovers at 10 m
    for m in before + across:
        assert abs(m.z + 10.0) < 0.2, m              # done-when: within 0.2 m of -10
    assert abs(gp.relative_alt / 1000.0 + sum(m.z for m in before) / len(before)) < 0.2
    seq = first[-1:] + before + across
    for a, b in zip(across, across[1:]):
        assert max(abs(b.x - a.x), abs(b.y - a.y), abs(b.z - a.z)) < 0.3, (a, b)
    # north and east against the truth (S_I: x north, y west)
    tn, te = truth[-1].pos_i[0] - truth[0].pos_i[0], -(truth[-1].pos_i[1] - truth[0].pos_i[1])
    assert abs(seq[-1].x - tn) < 0.3 and abs(seq[-1].y - te) < 0.3, (seq[-1], tn, te)
