"""Bad MAVLink input and parameter storage: every bad request gets the answer the
MAVLink rules give (docs/mavlink.md) and changes nothing (the whole parameter list is
compared before and after); octo-fw killed with SIGKILL during parameter saves always
leaves the complete old or the complete new file. Extends test_fw_mavlink.py."""

import os
import random
import signal
import socket
import struct
import subprocess
import time

from conftest import binary
from test_fw_rig import Rig, mavlink

NAN, INF = float("nan"), float("inf")


def fw_alone(launch, port, tmp_path, *args):
    rig = Rig(launch, port, tmp_path)
    rig.start_fw(*args)
    rig.connect()
    return rig


def snapshot(rig):
    count, got = rig.param_list()
    assert count and len(got) == count
    return {m.param_id: struct.pack("<f", m.param_value) for m in got.values()}


def test_bad_requests_get_their_answers_and_change_nothing(launch, port, tmp_path):
    rig = fw_alone(launch, port, tmp_path)
    before = snapshot(rig)
    table = dict(before)

    # PARAM_SET refused: PARAM_VALUE with the current value, and a STATUSTEXT saying why
    for name, value in (("VEH_KF", NAN), ("VEH_KF", INF), ("VEH_KF", -INF), ("VEH_KF", 0.5),
                        ("VEH_KF", 1e30), ("VEH_MASS", -1.0), ("MOT_THR_MAX", 1.0001),
                        ("NAV_TOUCH_DOWN_S", 1e-9), ("ATT_ZETA", -0.0), ("ID_KF_EST", 28.0)):
        msg, texts = rig.param_set(name, value)
        assert msg is not None, (name, value)
        assert struct.pack("<f", msg.param_value) == table[name], (name, value, msg.param_value)
        assert msg.param_type == mavlink.MAV_PARAM_TYPE_REAL32
        assert any(name in t for t in texts), (name, value, texts)
    # unknown names (also empty, 16 characters, not printable): no PARAM_VALUE, a STATUSTEXT
    for name in (b"NOT_A_PARAM", b"VEH_KF_", b"veh_kf", b"ABCDEFGHIJKLMNOP", b"\x01\xff\x7f", b""):
        start = len(rig.texts)
        rig.m.mav.param_set_send(1, 1, name, 1.0, mavlink.MAV_PARAM_TYPE_REAL32)
        assert rig.recv({"PARAM_VALUE"}, timeout=0.15) is None, name
        assert any("Unknown parameter" in t for t in rig.texts[start:]), (name, rig.texts[start:])
    # reads of unknown names and indexes out of range: no PARAM_VALUE
    for name, index in ((b"NOPE", -1), (b"", 10000), (b"", -2), (b"", 32767)):
        rig.m.mav.param_request_read_send(1, 1, name, index)
        assert rig.recv({"PARAM_VALUE"}, timeout=0.15) is None, (name, index)

    # commands with bad parameters: DENIED; unknown: UNSUPPORTED; never silence
    C = mavlink
    for cmd, params, want in (
            (C.MAV_CMD_COMPONENT_ARM_DISARM, [2], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_COMPONENT_ARM_DISARM, [NAN], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 1000.0], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 0.2], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_USER_1, [7], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_USER_1, [1.5], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_USER_1, [NAN], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_USER_1, [-INF], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_PREFLIGHT_STORAGE, [2], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_PREFLIGHT_STORAGE, [NAN], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_SET_MESSAGE_INTERVAL, [99999, 1000], C.MAV_RESULT_UNSUPPORTED),
            (C.MAV_CMD_SET_MESSAGE_INTERVAL, [NAN, 1000], C.MAV_RESULT_UNSUPPORTED),
            (C.MAV_CMD_SET_MESSAGE_INTERVAL, [C.MAVLINK_MSG_ID_LOCAL_POSITION_NED, NAN], C.MAV_RESULT_DENIED),
            (C.MAV_CMD_REQUEST_MESSAGE, [-5], C.MAV_RESULT_UNSUPPORTED),
            (C.MAV_CMD_REQUEST_MESSAGE, [1e12], C.MAV_RESULT_UNSUPPORTED),
            (42424, [1, 2, 3], C.MAV_RESULT_UNSUPPORTED)):
        r, texts = rig.cmd(cmd, *params)
        assert r == want, (cmd, params, r, texts)
    # regression (fuzz finding, tests/fuzz/regress/mavlink/set_interval_1e30): an interval
    # too large for the integer it is kept in is clamped, not undefined behaviour
    r, _ = rig.cmd(C.MAV_CMD_SET_MESSAGE_INTERVAL, C.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 1e30)
    assert r == C.MAV_RESULT_ACCEPTED
    r, _ = rig.cmd(C.MAV_CMD_SET_MESSAGE_INTERVAL, C.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 0)  # default again
    assert r == C.MAV_RESULT_ACCEPTED

    # packets for another system: no answer at all, nothing changes
    for tsys in (7, 255):
        rig.m.mav.param_set_send(tsys, 1, b"VEH_KF", 25.0, C.MAV_PARAM_TYPE_REAL32)
        rig.m.mav.command_long_send(tsys, 1, C.MAV_CMD_PREFLIGHT_STORAGE, 0, 1, 0, 0, 0, 0, 0, 0)
        rig.m.mav.command_long_send(tsys, 1, C.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        rig.m.mav.param_request_read_send(tsys, 1, b"VEH_KF", -1)
    rig.m.mav.param_set_send(1, 42, b"VEH_KF", 25.0, C.MAV_PARAM_TYPE_REAL32)   # another component
    assert rig.recv({"PARAM_VALUE", "COMMAND_ACK"}, timeout=0.5) is None

    # truncated, oversized and concatenated frames on the raw socket
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    mav = mavlink.MAVLink(None, srcSystem=250, srcComponent=190)
    good = mavlink.MAVLink_param_set_message(1, 1, b"VEH_KF", 26.0, 9).pack(mav)
    s.sendto(good[:-3], ("127.0.0.1", rig.mav_port))                       # truncated
    bad = bytearray(good)
    bad[1] = 255                                                           # length field too large
    s.sendto(bytes(bad) + bytes(300), ("127.0.0.1", rig.mav_port))
    s.sendto(bytes([0xFD, 0xFF]) + os.urandom(3000), ("127.0.0.1", rig.mav_port))  # > 2048 bytes
    s.sendto(os.urandom(65000), ("127.0.0.1", rig.mav_port))               # the largest datagram
    crc = bytearray(good)
    crc[-1] ^= 0xFF                                                        # bad checksum
    s.sendto(bytes(crc), ("127.0.0.1", rig.mav_port))
    v1 = bytearray(good)
    v1[0] = 0xFE                                                           # MAVLink 1 start byte
    s.sendto(bytes(v1), ("127.0.0.1", rig.mav_port))
    s.close()
    time.sleep(0.3)
    assert rig.recv({"PARAM_VALUE"}, timeout=0.3) is None
    assert rig.fw.alive()

    after = snapshot(rig)
    assert after == before
    assert not rig.params.exists()          # no storage command ran
    st = rig.recv({"SYS_STATUS"}, timeout=2.5)
    assert st is not None and st.errors_comm >= 1    # the bad checksum, counted


def parse_param_file(text, names):
    """The file is complete iff it is the header and one line per parameter, in table order."""
    lines = text.split("\n")
    if not text.endswith("\n") or not lines[0].startswith("#"):
        return None
    body = lines[1:-1]
    if [ln.split()[0] for ln in body if ln.split()] != names or len(body) != len(names):
        return None
    return {ln.split()[0]: float(ln.split()[1]) for ln in body}


def test_sigkill_during_parameter_saves_leaves_old_or_new_file(launch, port, tmp_path):
    """REPS lives of octo-fw: each sets VEH_KF to a new value and saves, many times, and is
    killed with SIGKILL at a random moment; the file is always a complete version."""
    import json
    table = json.loads(subprocess.run([binary("octo-fw"), "--dump-params"], capture_output=True,
                                      text=True, timeout=10).stdout)["params"]
    names = [p["name"] for p in table]
    rng = random.Random(9)
    path = tmp_path / "params.parm"
    mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    written = {20.0}                       # VEH_KF values a complete file may hold
    REPS, t_end = 60, time.monotonic() + 20
    reps = kills_mid_save = 0
    prev_text = None
    seen = set()                           # VEH_KF values found in complete files
    while reps < REPS and time.monotonic() < t_end:
        mav_port = port()
        fw = launch("octo-fw", "--mavlink-listen", mav_port, "--gcs", f"127.0.0.1:{port()}",
                    "--xp-listen", port(), "--xplane", f"127.0.0.1:{port()}", "--params", path)
        (tmp_path / "params.parm.tmp").unlink(missing_ok=True)
        time.sleep(0.01)
        kill_at = time.monotonic() + rng.uniform(0.0, 0.04)
        k = 0
        while time.monotonic() < kill_at:
            v = 20.0 + reps + k / 1000.0
            written.add(struct.unpack("<f", struct.pack("<f", v))[0])
            s.sendto(mavlink.MAVLink_param_set_message(1, 1, b"VEH_KF", v, 9).pack(mav), ("127.0.0.1", mav_port))
            s.sendto(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_PREFLIGHT_STORAGE, 0, 1,
                                                          0, 0, 0, 0, 0, 0).pack(mav), ("127.0.0.1", mav_port))
            k += 1
        os.killpg(fw.pid, signal.SIGKILL)   # launch() starts each in its own process group
        fw.wait(timeout=5)
        if (tmp_path / "params.parm.tmp").exists():
            kills_mid_save += 1            # killed between the temporary file and the rename
        reps += 1
        if not path.exists():
            continue
        text = path.read_text()
        got = parse_param_file(text, names)
        assert got is not None, f"repetition {reps}: damaged file:\n{text}"
        assert got["VEH_KF"] in written or any(abs(got["VEH_KF"] - w) < 1e-6 * w for w in written)
        seen.add(got["VEH_KF"])
        prev_text = text
    s.close()
    print(f"{reps} SIGKILLs, {kills_mid_save} with a save in flight (temporary file left), "
          f"{len(seen)} distinct complete versions seen")
    assert reps >= 50 and prev_text is not None
    assert kills_mid_save >= 1
    assert len(seen) >= 10                 # the saves really happened, life after life
    # the last file loads cleanly
    fw = launch("octo-fw", "--mavlink-listen", port(), "--gcs", f"127.0.0.1:{port()}", "--xp-listen", port(),
                "--xplane", f"127.0.0.1:{port()}", "--params", path)
    time.sleep(0.3)
    fw.stop()
    err = fw.stderr_path.read_text()
    assert "damaged" not in err and "no parameter file" not in err, err
