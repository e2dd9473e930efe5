"""octo-sim's flight-controller sensors on the wire (docs/sensors.md): `--sensors LIST` and the
vehicle key `sensors` choose what the plant serves; a row not served is not sent and its
datarefs reply 0 (as unknown ones); the IMU reads +1 g up at rest; the ESC rpm follows the
throttle in rows 37 and 38."""

import json
import subprocess

import pytest

import xplane_proto as xp
from conftest import binary, wait_until
from test_sim_support import HOVER, SimUnderTest

SENSOR_ROWS = (4, 16, 17, 35, 36, 37, 38)
PATHS = {
    1: "sim/flightmodel/position/Prad",
    2: "sim/flightmodel/forces/g_nrml",
    3: "sim/flightmodel/engine/POINT_thrust[0]",
    4: "sim/flightmodel/engine/ENGN_TRQ[0]",
    5: "sim/flightmodel/engine/POINT_tacrad[0]",
    6: "sim/flightmodel/position/theta",
}


def frames(s, n, u):
    """n lockstep frames at throttles u after the start; the last one."""
    f = s.start_lockstep(u)
    for _ in range(n - 1):
        f = s.step(u)
    return f


def test_sensors_imu_serves_rows_4_and_16_only(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--sensors", "imu", rows=SENSOR_ROWS)
    for idx, path in PATHS.items():
        s.send(xp.encode_rref(90, idx, path))
    f = frames(s, 30, [HOVER * 0.5] * 8)
    assert sorted(f) == [4, 16, 17], f.keys()
    assert f[4][4] == pytest.approx(1.0, abs=0.05)       # on the ground: +1 g normal
    def replies():
        r = s.link.recv_type("RREF", timeout=1)
        return dict(xp.decode_rref(r)) if r else None
    v = wait_until(lambda: (lambda d: d if d and len(d) == len(PATHS) else None)(replies()), timeout=3)
    assert v, s.proc.stderr()
    assert v[3] == 0.0 and v[4] == 0.0 and v[5] == 0.0   # thrust, torque, rotor speed: not served
    assert v[2] == pytest.approx(1.0, abs=0.05)
    c = s.counters()
    assert c["rref_unknown"] > 0


def test_default_serves_every_sensor_and_rpm_follows_the_throttle(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--ideal", rows=SENSOR_ROWS)
    f0 = s.next_data()
    assert sorted(f0) == list(SENSOR_ROWS)
    assert (f0[4][4], f0[4][5], f0[4][6]) == (1.0, 0.0, 0.0)   # ideal, at rest: exactly +1 g up
    assert f0[37][:8] == (0.0,) * 8                          # rotors stopped
    f_low = frames(s, 20, [HOVER * 0.5] * 8)
    rpm_low = f_low[37][0]
    for _ in range(20):
        f_high = s.step([HOVER * 2.0] * 8)
    rpm_high = f_high[37][0]
    assert rpm_low > 0 and f_low[38][:8] == f_low[37][:8]
    # speed^2 ~ thrust ~ throttle (linear curve): twice .. four times the throttle, 2x in rpm
    assert rpm_high / rpm_low == pytest.approx(2.0, rel=0.02)
    assert f_high[35][0] > 0 and f_high[36][0] > 0


def test_vehicle_key_sensors_and_the_flag_overrides_it(launch, port, tmp_path):
    veh = tmp_path / "v.json"
    veh.write_text(json.dumps({"sensors": ["thrust", "torque"]}))
    s = SimUnderTest(launch, port, "--vehicle", str(veh), rows=SENSOR_ROWS)
    f = s.next_data()
    assert sorted(f) == [17, 35, 36]
    s.stop()
    s = SimUnderTest(launch, port, "--vehicle", str(veh), "--sensors", "rpm,imu", rows=SENSOR_ROWS)
    f = s.next_data()
    assert sorted(f) == [4, 16, 17, 37, 38]


@pytest.mark.parametrize("args,word", [
    (["--sensors", "imu,gps"], "--sensors"),
    (["--sensors", ""], "--sensors"),
])
def test_bad_sensors_exit_2(args, word):
    r = subprocess.run([binary("octo-sim"), *args], capture_output=True, text=True, timeout=10)
    assert r.returncode == 2 and word in r.stderr, r.stderr


def test_bad_sensor_keys_exit_2_naming_the_key(tmp_path):
    for text, key in (({"sensors": ["sonar"]}, "sensors"), ({"vibration": {"cutoff_hz": 900}}, "vibration.cutoff_hz"),
                      ({"imu_bias": {"accel": -1}}, "imu_bias.accel"), ({"noise": {"rpm": -2}}, "noise.rpm")):
        veh = tmp_path / "bad.json"
        veh.write_text(json.dumps(text))
        r = subprocess.run([binary("octo-sim"), "--vehicle", str(veh)], capture_output=True, text=True, timeout=10)
        assert r.returncode == 2 and f"'{key}'" in r.stderr, r.stderr


def test_fw_converts_row_4_and_row_38_into_its_frame(launch, port, tmp_path):
    """octo-fw asks for rows 4 and 38 and converts them in its one place: the load factors
    (normal up +, axial forward +, side right +) into the specific force over g in FLU, the
    prop rpm into rad/s; the fw frame log carries both with their validity bits."""
    import math
    import struct
    import time
    from test_fw_rig import read_log
    from test_fw_xplane import start, frame

    rig, fake = start(launch, port, tmp_path)
    fake.pump(0.3)
    dsel = fake.of_type(b"DSEL")
    assert dsel and {4, 38} <= set(struct.unpack(f"<{(len(dsel[0]) - 5) // 4}i", dsel[0][5:]))
    _, index, _ = xp.decode_rref_request(fake.of_type(b"RREF")[0])
    for d in xp.encode_rref_reply([(index, 120100.0)]):
        fake.send(d)
    time.sleep(0.05)
    rpm = [1000.0 * (j + 1) for j in range(8)]
    for k in range(20):
        d = frame(10.0 + k / 90.0, 12)
        d += struct.pack("<i8f", 4, 0.0, -999.0, 0.0, -999.0, 1.02, 0.1, 0.2, -999.0)
        d += struct.pack("<i8f", 38, *rpm)
        fake.send(d)
        fake.pump(0.01)
    rig.fw.stop()
    fake.close()
    f = [r for r in read_log(rig.fw_log, "OCTO_FW_FRAME") if r.valid & (3 << 8) == (3 << 8)][-1]
    assert f.accel_b == pytest.approx((0.1, -0.2, 1.02), abs=1e-6)
    assert f.rotor_speed == pytest.approx([v * 2 * math.pi / 60 for v in rpm], rel=1e-6)


def test_static_vehicle_reads_plus_one_g_up_through_the_pipeline(launch, tmp_path):
    """octo-sim's row 4 through octo-fw's conversion: landed and level, the frame holds
    (0, 0, +1) g in FLU, with its validity bit, and rotor speeds of 0."""
    from test_fw_rig import read_log

    log = tmp_path / "fw.log"
    p = launch("octo-sil", "--ideal", "--duration", "0.5", "--quiet", "--lcm-fw", f"file://{log}")
    assert wait_until(lambda: not p.alive(), timeout=20) and p.stop() == 0, p.stderr()
    frames_ = [r for r in read_log(log, "OCTO_FW_FRAME") if r.valid & (1 << 8)]
    assert frames_, p.stderr()
    for f in frames_:
        assert tuple(f.accel_b) == (0.0, 0.0, 1.0)
        assert f.valid & (1 << 9) and tuple(f.rotor_speed) == (0.0,) * 8
