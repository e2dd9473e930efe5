"""octo-fw's MAVLink side through pymavlink: parameters, storage, commands,
telemetry; and its command line. Most tests run octo-fw alone (no plant)."""

import json
import math
import struct
import subprocess
import time

from conftest import binary, free_port
from test_fw_rig import Rig, mavlink


def dump_params():
    r = subprocess.run([binary("octo-fw"), "--dump-params"], capture_output=True, text=True, timeout=10)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)["params"]


def fw_alone(launch, port, tmp_path, *fw_args):
    rig = Rig(launch, port, tmp_path)
    rig.start_fw(*fw_args)
    rig.connect()
    return rig


# ---------------------------------------------------------------- command line
def test_dump_params_is_the_table():
    table = dump_params()
    names = [p["name"] for p in table]
    assert len(names) == len(set(names))
    assert [p["index"] for p in table] == list(range(len(table)))
    for p in table:
        assert 1 <= len(p["name"]) <= 16 and p["type"] == "REAL32"
        assert p["min"] <= p["default"] <= p["max"]
        assert p["description"]
    d = {p["name"]: p for p in table}
    for name in ("VEH_KF", "VEH_KTAU", "VEH_IXX", "VEH_IYY", "VEH_IZZ", "VEH_MASS", "VEH_ARM_L"):
        assert name in d
    # the deliberately wrong nominal values of the issue
    assert d["VEH_KF"]["default"] == 20 and d["VEH_KTAU"]["default"] == 0.3
    assert d["VEH_IXX"]["default"] == d["VEH_IYY"]["default"] == d["VEH_IZZ"]["default"] == 0.05
    assert d["VEH_MASS"]["default"] == 2.132 and d["VEH_ARM_L"]["default"] == 0.35


def test_bad_flags_exit_2_naming_the_flag():
    fw = binary("octo-fw")
    for argv, needle in ((["--nope"], "--nope"), (["--xp-listen", "0"], "--xp-listen"),
                         (["--xplane", "nohostport"], "--xplane"), (["--actuation", "pwm"], "--actuation"),
                         (["--gcs"], "--gcs"), (["--signing-key", "k.bin"], "--signing-key")):
        r = subprocess.run([fw, *argv], capture_output=True, text=True, timeout=10)
        assert r.returncode == 2, (argv, r.stderr)
        assert needle in r.stderr


def test_second_fw_on_a_taken_xplane_port_is_refused(tmp_path):
    # two vehicles must never share the X-Plane port (each would fly on the other's frames)
    fw, xp, mav = binary("octo-fw"), free_port(), free_port()
    first = subprocess.Popen([fw, "--xp-listen", str(xp), "--mavlink-listen", str(mav),
                              "--params", str(tmp_path / "a.parm")],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 10
        while "flying X-Plane" not in (first.stderr.readline() or "") and time.monotonic() < deadline:
            assert first.poll() is None
        r = subprocess.run([fw, "--xp-listen", str(xp), "--mavlink-listen", str(free_port()),
                            "--params", str(tmp_path / "b.parm")], capture_output=True, text=True, timeout=10)
        assert r.returncode == 1, r.stderr
        assert f"cannot bind X-Plane port {xp}" in r.stderr, r.stderr
    finally:
        first.terminate()
        first.wait(timeout=10)


# ---------------------------------------------------------------- parameters
def test_param_list_is_complete_and_consistent(launch, port, tmp_path):
    table = dump_params()
    rig = fw_alone(launch, port, tmp_path)
    t0 = time.monotonic()
    count, got = rig.param_list()
    assert count == len(table)
    assert sorted(got) == list(range(count))
    for i, p in enumerate(table):
        msg = got[i]
        assert msg.param_id == p["name"]
        assert msg.param_type == mavlink.MAV_PARAM_TYPE_REAL32
        assert msg.param_count == count
        assert math.isclose(msg.param_value, p["default"], rel_tol=1e-6)
    assert time.monotonic() - t0 < 5.0
    # a second list gives the same table (it never changes under a GCS)
    count2, got2 = rig.param_list()
    assert count2 == count and [m.param_id for _, m in sorted(got2.items())] == [p["name"] for p in table]


def test_param_read_by_name_and_by_index(launch, port, tmp_path):
    table = dump_params()
    rig = fw_alone(launch, port, tmp_path)
    msg = rig.param_get("VEH_KTAU")
    assert msg is not None and math.isclose(msg.param_value, 0.3, rel_tol=1e-6)
    idx = [p["name"] for p in table].index("VEH_IZZ")
    assert msg.param_index == [p["name"] for p in table].index("VEH_KTAU")
    # by index with an empty name, as MAVProxy re-reads missing entries (component 0)
    rig.m.mav.param_request_read_send(1, 0, b"", idx)
    m2 = rig.recv({"PARAM_VALUE"}, timeout=2)
    assert m2 is not None and m2.param_id == "VEH_IZZ" and m2.param_index == idx
    # unknown name / index: no PARAM_VALUE, a STATUSTEXT
    rig.texts.clear()
    rig.m.mav.param_request_read_send(1, 1, b"NO_SUCH_PARAM", -1)
    assert rig.recv({"PARAM_VALUE"}, timeout=0.5) is None
    rig.m.mav.param_request_read_send(1, 1, b"", 9999)
    assert rig.recv({"PARAM_VALUE"}, timeout=0.5) is None
    assert any("NO_SUCH_PARAM" in t for t in rig.texts), rig.texts
    assert any("9999" in t for t in rig.texts), rig.texts


def test_param_set_accepted_refused_and_unknown(launch, port, tmp_path):
    rig = fw_alone(launch, port, tmp_path)
    msg, texts = rig.param_set("VEH_KF", 27.5)
    assert msg is not None and msg.param_value == 27.5 and msg.param_type == mavlink.MAV_PARAM_TYPE_REAL32
    assert rig.param_get("VEH_KF").param_value == 27.5
    # refused writes echo the current value, and say why
    for bad in (1e6, -3.0, float("nan"), float("inf")):
        msg, texts = rig.param_set("VEH_KF", bad)
        assert msg is not None and msg.param_value == 27.5, bad
        assert any("VEH_KF" in t and "refused" in t for t in texts), texts
    # unknown name: no PARAM_VALUE, a STATUSTEXT
    msg, texts = rig.param_set("NOT_A_PARAM", 1.0)
    assert msg is None
    assert any("NOT_A_PARAM" in t for t in texts), texts
    # an exactly 16-character unknown id (no NUL on the wire) is handled too
    msg, texts = rig.param_set("ABCDEFGHIJKLMNOP", 1.0)
    assert msg is None and any("ABCDEFGHIJKLMNOP" in t for t in texts), texts
    # identification results are read-only
    msg, texts = rig.param_set("ID_KF_EST", 5.0)
    assert msg is not None and msg.param_value == 0.0
    assert any("ID_KF_EST" in t and "read-only" in t for t in texts), texts
    # a name of exactly 16 characters travels without NUL and is matched whole
    msg, texts = rig.param_set("NAV_TOUCH_DOWN_S", 1.5)
    assert msg is not None and msg.param_id == "NAV_TOUCH_DOWN_S" and msg.param_value == 1.5, texts
    assert rig.param_get("NAV_TOUCH_DOWN_S").param_value == 1.5
    # messages for another system are ignored
    rig.m.mav.param_set_send(7, 1, b"VEH_KF", 30.0, mavlink.MAV_PARAM_TYPE_REAL32)
    assert rig.recv({"PARAM_VALUE"}, timeout=0.4) is None
    assert rig.param_get("VEH_KF").param_value == 27.5


def test_params_persist_across_restart(launch, port, tmp_path):
    rig = fw_alone(launch, port, tmp_path)
    # the answer holds the value as float32 stores it
    assert rig.param_set("VEH_KTAU", 0.3869)[0].param_value == struct.unpack("<f", struct.pack("<f", 0.3869))[0]
    assert rig.param_set("VEH_IXX", 0.0628)[0] is not None
    r, texts = rig.cmd(mavlink.MAV_CMD_PREFLIGHT_STORAGE, 1)
    assert r == mavlink.MAV_RESULT_ACCEPTED, texts
    text = rig.params.read_text()
    assert "VEH_KTAU" in text and "0.3869" in text
    assert not (tmp_path / "params.parm.tmp").exists()
    rig.fw.stop()
    rig.close_gcs()
    rig.start_fw()
    rig.connect()
    assert math.isclose(rig.param_get("VEH_KTAU").param_value, 0.3869, rel_tol=1e-6)
    assert math.isclose(rig.param_get("VEH_IXX").param_value, 0.0628, rel_tol=1e-6)
    # a change not saved is reverted by a load (PREFLIGHT_STORAGE read)
    rig.param_set("VEH_IXX", 0.07)
    r, _ = rig.cmd(mavlink.MAV_CMD_PREFLIGHT_STORAGE, 0)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    # the loaded values are streamed to the ground station (its copy was stale)
    pushed = None
    end = time.monotonic() + 3
    while pushed is None and time.monotonic() < end:
        m = rig.recv({"PARAM_VALUE"}, timeout=0.5)
        if m is not None and m.param_id == "VEH_IXX":
            pushed = m
    assert pushed is not None and math.isclose(pushed.param_value, 0.0628, rel_tol=1e-6)
    assert math.isclose(rig.param_get("VEH_IXX").param_value, 0.0628, rel_tol=1e-6)


def test_damaged_param_file_lines_are_reported_and_defaults_kept(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    rig.params.write_text("# comment\nVEH_KF 25.5\nVEH_KTAU banana\nVEH_IXX 1e9\nWHAT 3\n"
                          "VEH_IYY 0.07\nVEH_IZZ\n\x00\x01garbage line with words\n")
    rig.start_fw()
    rig.connect()
    assert rig.param_get("VEH_KF").param_value == 25.5
    assert math.isclose(rig.param_get("VEH_IYY").param_value, 0.07, rel_tol=1e-6)
    assert math.isclose(rig.param_get("VEH_KTAU").param_value, 0.3, rel_tol=1e-6)
    assert math.isclose(rig.param_get("VEH_IXX").param_value, 0.05, rel_tol=1e-6)
    assert math.isclose(rig.param_get("VEH_IZZ").param_value, 0.05, rel_tol=1e-6)
    err = rig.fw.stderr()
    for line in (3, 4, 5, 7, 8):
        assert f"line {line}:" in err, err
    assert "line 2:" not in err and "line 6:" not in err


# ---------------------------------------------------------------- commands
def test_commands_are_acknowledged_per_the_rules(launch, port, tmp_path):
    rig = fw_alone(launch, port, tmp_path)
    C, R = mavlink, mavlink
    # unknown command
    assert rig.cmd(42424)[0] == R.MAV_RESULT_UNSUPPORTED
    # no position yet, so no home: not now (MAVProxy and MAVSDK ask again)
    assert rig.cmd(C.MAV_CMD_GET_HOME_POSITION)[0] == R.MAV_RESULT_TEMPORARILY_REJECTED
    # no plant frames yet: cannot arm (and retries get the same answer)
    r1, texts = rig.cmd(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    r2, _ = rig.cmd(C.MAV_CMD_COMPONENT_ARM_DISARM, 1, confirmation=1)
    assert r1 == r2 == R.MAV_RESULT_TEMPORARILY_REJECTED and texts
    assert rig.cmd(C.MAV_CMD_COMPONENT_ARM_DISARM, 7)[0] == R.MAV_RESULT_DENIED
    assert rig.cmd(C.MAV_CMD_COMPONENT_ARM_DISARM, 0)[0] == R.MAV_RESULT_ACCEPTED   # already disarmed
    assert rig.cmd(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)[0] == R.MAV_RESULT_TEMPORARILY_REJECTED
    assert rig.cmd(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 500)[0] == R.MAV_RESULT_DENIED
    assert rig.cmd(C.MAV_CMD_NAV_LAND)[0] == R.MAV_RESULT_ACCEPTED
    # experiments: bad id DENIED, not hovering DENIED
    assert rig.cmd(C.MAV_CMD_USER_1, 9)[0] == R.MAV_RESULT_DENIED
    assert rig.cmd(C.MAV_CMD_USER_1, 1.5)[0] == R.MAV_RESULT_DENIED
    r, texts = rig.cmd(C.MAV_CMD_USER_1, 1)
    assert r == R.MAV_RESULT_DENIED and any("hovering" in t for t in texts), texts
    # storage: bad param1 DENIED; write without --params file is a failure here? (we have one)
    assert rig.cmd(C.MAV_CMD_PREFLIGHT_STORAGE, 5)[0] == R.MAV_RESULT_DENIED
    assert rig.cmd(C.MAV_CMD_PREFLIGHT_STORAGE, 1)[0] == R.MAV_RESULT_ACCEPTED
    # addressed to component 0 (broadcast) is answered too
    assert rig.cmd(42424, target_component=0)[0] == R.MAV_RESULT_UNSUPPORTED


def test_autopilot_version_and_request_message(launch, port, tmp_path):
    rig = fw_alone(launch, port, tmp_path)
    r, _ = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    v = rig.recv({"AUTOPILOT_VERSION"}, timeout=2)
    assert v is not None
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, 9999)[0] == mavlink.MAV_RESULT_UNSUPPORTED
    r, _ = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION)
    assert r == mavlink.MAV_RESULT_ACCEPTED
    # no plant: no position, so no local origin yet
    r, _ = rig.cmd(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED)
    assert r == mavlink.MAV_RESULT_TEMPORARILY_REJECTED


def test_heartbeat_and_message_intervals(launch, port, tmp_path):
    rig = fw_alone(launch, port, tmp_path)
    hb = rig.recv({"HEARTBEAT"}, timeout=3)
    assert hb.type == mavlink.MAV_TYPE_OCTOROTOR and hb.autopilot == mavlink.MAV_AUTOPILOT_GENERIC
    assert hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1
    assert not (hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    assert hb.system_status == mavlink.MAV_STATE_STANDBY

    def rate(msg_type, seconds=1.0):
        n, t_end = 0, time.monotonic() + seconds
        while time.monotonic() < t_end:
            if rig.recv({msg_type}, timeout=t_end - time.monotonic()) is not None:
                n += 1
        return n / seconds

    base = rate("ATTITUDE_QUATERNION")
    assert 5 <= base <= 15, base
    ATT = mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION
    assert rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ATT, 20000)[0] == mavlink.MAV_RESULT_ACCEPTED
    assert rate("ATTITUDE_QUATERNION") >= 35
    assert rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ATT, -1)[0] == mavlink.MAV_RESULT_ACCEPTED
    rig.recv(set(), timeout=0.1)
    assert rate("ATTITUDE_QUATERNION", 0.5) == 0
    assert rig.cmd(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 1000)[0] == mavlink.MAV_RESULT_UNSUPPORTED
    assert rig.recv({"ACTUATOR_OUTPUT_STATUS"}, timeout=1) is not None
    assert rig.recv({"SERVO_OUTPUT_RAW"}, timeout=1) is not None


def test_mission_ftp_and_gcs_learning(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    # the configured --gcs port is unused: the GCS is learned from incoming packets
    rig.gcs_port = port()
    rig.start_fw()
    from pymavlink import mavutil
    m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{rig.mav_port}", source_system=255)
    rig.m = m
    hb = None
    for _ in range(30):   # octo-fw may not have bound its port yet: repeat, as a GCS does
        m.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        hb = rig.recv({"HEARTBEAT"}, timeout=0.3)
        if hb is not None:
            break
    assert hb is not None
    m.mav.mission_request_list_send(1, 0)
    mc = rig.recv({"MISSION_COUNT"}, timeout=2)
    assert mc is not None and mc.count == 0
    payload = bytearray(251)
    payload[0:2] = (7).to_bytes(2, "little")
    payload[3] = 4   # OpenFileRO
    m.mav.file_transfer_protocol_send(0, 1, 1, payload)
    ftp = rig.recv({"FILE_TRANSFER_PROTOCOL"}, timeout=2)
    assert ftp is not None
    p = bytes(ftp.payload)
    assert p[3] == 129 and p[5] == 4 and p[12] == 10   # NAK of OpenFileRO: FileNotFound
    assert int.from_bytes(p[0:2], "little") == 8


def test_experiment_when_hovering_is_answered(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    rig.start()
    rig.takeoff_and_hold(2.0)
    rig.recv(set(), timeout=0.3)
    r, texts = rig.cmd(mavlink.MAV_CMD_USER_1, 1)
    # long-running: IN_PROGRESS now, a final ACK later (or UNSUPPORTED in a build without)
    assert r in (mavlink.MAV_RESULT_IN_PROGRESS, mavlink.MAV_RESULT_UNSUPPORTED), (r, texts)
    if r == mavlink.MAV_RESULT_UNSUPPORTED:
        assert any("not available" in t for t in texts), texts
    else:
        # while it runs, vehicle-model parameters are locked: the write echoes the old value
        msg, texts = rig.param_set("VEH_KF", 22.0)
        assert msg is not None
        if msg.param_value != 22.0:
            assert any("VEH_KF" in t and "refused" in t for t in texts), texts
        # the final acknowledgement comes when it ends
        final = None
        deadline = time.monotonic() + 60
        while final is None and time.monotonic() < deadline:
            a = rig.recv({"COMMAND_ACK"}, timeout=0.5)
            if a is not None and a.command == mavlink.MAV_CMD_USER_1 and \
                    a.result != mavlink.MAV_RESULT_IN_PROGRESS:
                final = a
        assert final is not None and final.result in (mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_FAILED)
    # hovering without an experiment, the parameters may change
    rig.recv(set(), timeout=0.2)
    assert rig.param_set("VEH_KF", 22.0)[0].param_value == 22.0


# ---------------------------------------------------------------- signing
def test_signing_rejects_unsigned_wrong_and_replayed(launch, port, tmp_path):
    from pymavlink import mavutil
    key = bytes(range(1, 33))
    (tmp_path / "key.hex").write_text(key.hex() + "\n")
    rig = Rig(launch, port, tmp_path)
    rig.start_fw("--signing-key", tmp_path / "key.hex")
    rig.m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{rig.gcs_port}", source_system=255)
    rig.m.setup_signing(key, sign_outgoing=True)          # unsigned input is refused here too
    assert rig.m.wait_heartbeat(timeout=5) is not None    # so octo-fw signs what it sends
    msg, _ = rig.param_set("VEH_KF", 25.0)
    assert msg is not None and msg.param_value == 25.0

    # unsigned and wrongly signed writes are rejected (and do not steal the GCS address)
    plain = mavutil.mavlink_connection(f"udpout:127.0.0.1:{rig.mav_port}", source_system=254)
    plain.mav.param_set_send(1, 1, b"VEH_KF", 30.0, mavlink.MAV_PARAM_TYPE_REAL32)
    plain.mav.command_long_send(1, 1, mavlink.MAV_CMD_PREFLIGHT_STORAGE, 0, 1, 0, 0, 0, 0, 0, 0)
    wrong = mavutil.mavlink_connection(f"udpout:127.0.0.1:{rig.mav_port}", source_system=253)
    wrong.setup_signing(bytes(32), sign_outgoing=True)
    wrong.mav.param_set_send(1, 1, b"VEH_KF", 31.0, mavlink.MAV_PARAM_TYPE_REAL32)
    time.sleep(0.3)
    assert rig.param_get("VEH_KF").param_value == 25.0
    assert not rig.params.exists()

    # a replayed signed command is rejected: one ACK for two copies
    mav = mavlink.MAVLink(None, srcSystem=252, srcComponent=1)
    mav.signing.secret_key = key
    mav.signing.link_id = 3
    mav.signing.timestamp = int((time.time() - 1420070400) * 1e5)
    mav.signing.sign_outgoing = True
    pkt = mavlink.MAVLink_command_long_message(1, 1, 42424, 0, 0, 0, 0, 0, 0, 0, 0).pack(mav)
    s = rig.m.port    # from the GCS's own socket: octo-fw answers there
    s.sendto(pkt, ("127.0.0.1", rig.mav_port))
    s.sendto(pkt, ("127.0.0.1", rig.mav_port))
    acks = 0
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        a = rig.recv({"COMMAND_ACK"}, timeout=end - time.monotonic())
        if a is not None and a.command == 42424:
            acks += 1
    assert acks == 1
    st = None
    for _ in range(3):
        st = rig.recv({"SYS_STATUS"}, timeout=2)
        if st is not None and st.errors_count4 >= 4:
            break
    assert st is not None and st.errors_count4 >= 4     # rejected by signing, counted


def test_floods_and_garbage_are_limited_and_counted(launch, port, tmp_path):
    import os
    import socket
    rig = fw_alone(launch, port, tmp_path)
    for _ in range(300):
        rig.m.mav.param_request_read_send(1, 1, b"NOPE", -1)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rnd = __import__("random").Random(5)
    for _ in range(200):   # garbage, and MAVLink-looking frames with bad checksums
        b = bytearray(os.urandom(rnd.randrange(1, 300)))
        if rnd.random() < 0.5:
            b[0] = 0xFD
        s.sendto(bytes(b), ("127.0.0.1", rig.mav_port))
    s.close()
    texts = 0
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        if rig.recv({"STATUSTEXT"}, timeout=end - time.monotonic()) is not None:
            texts += 1
    assert 10 <= texts <= 80, texts             # a burst, then a rate: never 300
    st = None
    for _ in range(3):
        st = rig.recv({"SYS_STATUS"}, timeout=2)
        if st is not None and st.errors_count3 > 0:
            break
    assert st.errors_count3 >= 200              # STATUSTEXTs not sent, counted
    assert rig.fw.alive()
    assert rig.param_get("VEH_KF") is not None  # still answering


def test_truncated_packet_does_not_swallow_the_next_datagram(launch, port, tmp_path):
    import socket
    rig = fw_alone(launch, port, tmp_path)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for _ in range(5):
        # a MAVLink 2 header announcing 255 bytes of payload, then nothing
        s.sendto(bytes([0xFD, 0xFF, 0, 0, 7, 255, 190, 22, 0, 0]), ("127.0.0.1", rig.mav_port))
        msg = rig.param_get("VEH_MASS", timeout=1.0)
        assert msg is not None and math.isclose(msg.param_value, 2.132, rel_tol=1e-6)
    s.close()
