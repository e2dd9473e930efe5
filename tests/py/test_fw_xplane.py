"""octo-fw's X-Plane client against a fake X-Plane written from docs/xplane-protocol.md
(tests/py/xplane_proto.py): the requests it sends, its conventions (one place:
X-Plane NED/FRD/OpenGL -> the paper's NWU/FLU), actuation bytes, time
re-basing, and what it does with foreign and malformed datagrams."""

import math
import socket
import struct
import time

import pytest

import xplane_proto as xp
from test_fw_rig import Rig, mavlink, read_log


class FakeXPlane:
    """Binds the port octo-fw sends requests to; sends DATA from it (same IP)."""

    def __init__(self, port, fw_listen, ip="127.0.0.1"):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((ip, port))
        self.sock.settimeout(0.02)
        self.fw = ("127.0.0.1", fw_listen)
        self.got = []

    def pump(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                d, a = self.sock.recvfrom(4096)
                self.got.append(d)
            except socket.timeout:
                pass

    def of_type(self, tag):
        return [d for d in self.got if d[:4] == tag]

    def send(self, dgram):
        self.sock.sendto(dgram, self.fw)

    def close(self):
        self.sock.close()


def euler_quat_ned(phi, theta, psi):
    """X-Plane's q = [w, x, y, z] from roll, pitch, heading (deg), Z-Y-X."""
    hp, ht, hs = (math.radians(v) / 2 for v in (phi, theta, psi))
    cp, sp, ct, st, cs, ss = math.cos(hp), math.sin(hp), math.cos(ht), math.sin(ht), math.cos(hs), math.sin(hs)
    return (cp * ct * cs + sp * st * ss, sp * ct * cs - cp * st * ss,
            cp * st * cs + sp * ct * ss, cp * ct * ss - sp * st * cs)


PQR = (0.1, -0.2, 0.3)           # rad/s about forward, right, down
EULER = (5.0, 10.0, 90.0)        # roll, pitch, heading in degrees
GL = (3.0, 12.0, -4.0, 0.5, -1.0, 2.0)   # OpenGL x, y, z, vx, vy, vz


GL0 = (1.0, 11.5, -1.0)          # OpenGL x, y, z of the first fix: the local origin


def frame(t, version, extra_rows=(), gl=GL):
    if version >= 12:
        r16 = [math.degrees(PQR[0]), math.degrees(PQR[1]), math.degrees(PQR[2])]
    else:
        r16 = [PQR[1], PQR[0], PQR[2]]
    rows = {1: [t, t, t], 16: r16, 17: [EULER[1], EULER[0], EULER[2], EULER[2]],
            21: list(gl), 35: [1.0 * (j + 1) for j in range(8)], 36: [0.1 * (j + 1) for j in range(8)]}
    for r in extra_rows:
        rows[r] = [0.0] * 8
    return xp.encode_data(dict(sorted(rows.items())), byte4=xp.DATA_OUT_BYTE4)


def start(launch, port, tmp_path, actuation="dref"):
    rig = Rig(launch, port, tmp_path, actuation=actuation)
    fake = FakeXPlane(rig.xp_port, rig.xp_listen)
    rig.start_fw()
    rig.connect()
    return rig, fake


def test_requests_dsel_and_version_rref(launch, port, tmp_path):
    rig, fake = start(launch, port, tmp_path)
    fake.pump(2.3)
    dsel = fake.of_type(b"DSEL")
    assert len(dsel) >= 2, "DSEL must be re-sent while its rows are not seen"
    for d in dsel:
        assert d[4] == 0
        rows = struct.unpack(f"<{(len(d) - 5) // 4}i", d[5:])
        assert {1, 16, 17, 21, 35, 36} <= set(rows)
        assert d == xp.encode_dsel(rows)
    rref = fake.of_type(b"RREF")
    assert rref and all(len(d) == xp.RREF_REQUEST_SIZE for d in rref)
    freq, index, path = xp.decode_rref_request(rref[0])
    assert (freq, path) == (1, xp.VERSION_DATAREF)
    assert rref[0] == xp.encode_rref(1, index, xp.VERSION_DATAREF)
    fake.close()


@pytest.mark.parametrize("version", [110000, 120100])
def test_frame_conventions_in_one_place(launch, port, tmp_path, version):
    rig, fake = start(launch, port, tmp_path)
    fake.pump(0.2)
    _, index, _ = xp.decode_rref_request(fake.of_type(b"RREF")[0])
    for d in xp.encode_rref_reply([(index, float(version))]):
        fake.send(d)
    time.sleep(0.05)
    # the first fix sets the local origin (LOCAL_POSITION_NED is relative to it, as PX4's)
    for k in range(5):
        fake.send(frame(9.9 + k / 90.0, version // 10000, extra_rows=(3,), gl=GL0 + GL[3:]))
        fake.pump(0.01)
    for k in range(30):
        fake.send(frame(10.0 + k / 90.0, version // 10000, extra_rows=(3,)))
        fake.pump(0.01)
    # telemetry leaves in MAVLink's NED/FRD conventions: it must equal X-Plane's own. The
    # local position first: it is sent only while frames arrive (the link times out soon after)
    lp = latest(rig, "LOCAL_POSITION_NED")
    aq = latest(rig, "ATTITUDE_QUATERNION")
    qx = euler_quat_ned(*EULER)
    assert all(abs(a - b) < 1e-5 for a, b in zip((aq.q1, aq.q2, aq.q3, aq.q4), qx)), (aq.to_dict(), qx)
    assert all(abs(a - b) < 1e-5 for a, b in zip((aq.rollspeed, aq.pitchspeed, aq.yawspeed), PQR))
    n, e, d = (a - b for a, b in zip(xp.ned_from_opengl(*GL[:3]), xp.ned_from_opengl(*GL0)))
    vn, ve, vd = xp.ned_from_opengl(*GL[3:])
    assert [round(v, 4) for v in (lp.x, lp.y, lp.z, lp.vx, lp.vy, lp.vz)] == [round(v, 4) for v in (n, e, d, vn, ve, vd)]
    fake.pump(1.2)
    usel = fake.of_type(b"USEL")
    assert usel and 3 in struct.unpack(f"<{(len(usel[0]) - 5) // 4}i", usel[0][5:])
    rig.fw.stop()
    fake.close()
    # the log holds the paper's frames: NWU / FLU
    f = [r for r in read_log(rig.fw_log, "OCTO_FW_FRAME") if r.valid & 0xF == 0xF][-1]
    assert all(abs(a - b) < 1e-5 for a, b in zip(f.q, (qx[0], qx[1], -qx[2], -qx[3])))
    assert all(abs(a - b) < 1e-5 for a, b in zip(f.rate_b, (PQR[0], -PQR[1], -PQR[2])))
    assert [round(v, 4) for v in f.pos_i] == [-GL[2], -GL[0], GL[1]]
    assert [round(v, 4) for v in f.vel_i] == [-GL[5], -GL[3], GL[4]]
    assert abs(f.rotor_thrust[2] - 3.0 * xp.N_PER_LB) < 1e-4
    assert abs(f.rotor_torque[7] - 0.8 * xp.NM_PER_FTLB) < 1e-4


def latest(rig, msg_type, seconds=0.5):
    """The last message of a type that arrives within `seconds` (older ones are stale)."""
    last, end = None, time.monotonic() + seconds
    while time.monotonic() < end:
        m = rig.recv({msg_type}, timeout=end - time.monotonic())
        last = m or last
    assert last is not None, msg_type
    return last


def feed_until_armed(rig, fake, version=120100):
    fake.pump(0.2)
    _, index, _ = xp.decode_rref_request(fake.of_type(b"RREF")[0])
    for d in xp.encode_rref_reply([(index, float(version))]):
        fake.send(d)
    t = 1.0
    for _ in range(10):
        fake.send(frame(t, 12))
        t += 1 / 90
        fake.pump(0.01)
    rig.m.mav.command_long_send(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    ack = rig.recv({"COMMAND_ACK"}, timeout=2)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    fake.pump(0.1)
    fake.got.clear()
    return t


def test_actuation_drefs_once_per_frame(launch, port, tmp_path):
    rig, fake = start(launch, port, tmp_path)
    assert rig.param_set("MOT_THR_IDLE", 0.25)[0].param_value == 0.25
    t = feed_until_armed(rig, fake)
    for _ in range(5):
        fake.send(frame(t, 12))
        t += 1 / 90
        fake.pump(0.03)
    drefs = [xp.decode_dref(d) for d in fake.of_type(b"DREF")]
    assert all(len(d) == xp.DREF_SIZE for d in fake.of_type(b"DREF"))
    thro = [p for p, v in drefs if p.startswith(xp.THRO_USE)]
    assert len(thro) == 5 * 8
    assert sorted(set(thro)) == [f"{xp.THRO_USE}[{i}]" for i in range(8)]
    assert all(v == 0.25 for p, v in drefs if p.startswith(xp.THRO_USE))
    # byte for byte what the reference codec (X-Plane's byte vectors) encodes
    assert all(d == xp.encode_dref(*xp.decode_dref(d)) for d in fake.of_type(b"DREF"))
    rig.fw.stop()   # hands the throttles back
    fake.pump(0.2)
    assert any(p == xp.OVERRIDE_THROTTLES for p, _ in (xp.decode_dref(d) for d in fake.of_type(b"DREF")))


def test_actuation_data25_once_per_frame(launch, port, tmp_path):
    rig, fake = start(launch, port, tmp_path, actuation="data25")
    assert rig.param_set("MOT_THR_IDLE", 0.125)[0].param_value == 0.125
    t = feed_until_armed(rig, fake)
    for _ in range(5):
        fake.send(frame(t, 12))
        t += 1 / 90
        fake.pump(0.03)
    data = fake.of_type(b"DATA")
    assert len(data) == 5 and not fake.of_type(b"DREF")
    for d in data:
        assert len(d) == 41 and d[4] == 0
        rows = xp.decode_data(d)
        assert list(rows) == [25] and rows[25] == (0.125,) * 8
        assert d == xp.encode_data({25: [0.125] * 8})


def test_foreign_and_malformed_datagrams_are_dropped_and_counted(launch, port, tmp_path):
    rig, fake = start(launch, port, tmp_path)
    t = feed_until_armed(rig, fake)
    foreign = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    foreign.bind(("127.0.0.2", 0))
    bad = [b"", b"DAT", b"DATA\x2a" + b"\x01" * 35, b"RREF,\x01\x02", b"\xff" * 600, b"data*" + b"\0" * 36,
           b"DATA*", frame(t, 12)[:-3]]
    for d in bad:
        fake.send(d)
    for _ in range(7):
        foreign.sendto(frame(t, 12), fake.fw)
    fake.send(frame(t, 12))
    time.sleep(0.3)
    rig.m.mav.command_long_send(1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                mavlink.MAVLINK_MSG_ID_SYS_STATUS, 0, 0, 0, 0, 0, 0)
    st = None
    for _ in range(5):
        st = rig.recv({"SYS_STATUS"}, timeout=2)
        if st is not None and st.errors_count2 == 7:
            break
    # errors_count1: X-Plane datagrams dropped (malformed + foreign), errors_count2: foreign
    assert st.errors_count2 == 7
    assert st.errors_count1 >= 7 + len(bad) - 1    # an empty datagram may never arrive
    assert rig.fw.alive()
    foreign.close()


def test_time_is_rebased_never_backwards(launch, port, tmp_path):
    rig, fake = start(launch, port, tmp_path)
    t = feed_until_armed(rig, fake)
    # a reordered frame (older by one frame) carries no news; a reload (time back
    # to 0.5 s) is re-based to continue one frame after the last
    sent = (t, t + 2 / 90, t + 1 / 90, t + 3 / 90, 0.5, 0.5 + 1 / 90, 0.5 + 2 / 90)
    for tt in sent:
        fake.send(frame(tt, 12))
        fake.pump(0.02)
    # every frame with a new time is answered once; the reordered one is not
    assert len([d for d in fake.of_type(b"DREF") if xp.THRO_USE.encode() in d]) == 8 * (len(sent) - 1)
    rig.fw.stop()
    log = read_log(rig.fw_log, "OCTO_FW_FRAME")
    ts = [r.t for r in log]
    assert all(b >= a for a, b in zip(ts, ts[1:])), ts
    last = ts[-len(sent):]
    expect = [t, t + 2 / 90, t + 2 / 90, t + 3 / 90, t + 4 / 90, t + 5 / 90, t + 6 / 90]
    assert all(abs(a - b) < 1e-4 for a, b in zip(last, expect)), (last, expect)
    assert [r.stepped for r in log[-len(sent):]] == [True, True, False, True, True, True, True]
