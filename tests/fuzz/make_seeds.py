#!/usr/bin/env python3
"""Writes the committed seed corpora tests/fuzz/corpus/NAME/ (run from the
repository root with the project's venv: .venv/bin/python tests/fuzz/make_seeds.py).
Seeds are small valid inputs in each harness's record format (see the harness
sources); the fuzzer mutates from there."""

import os
import struct
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

OUT = Path(__file__).resolve().parent / "corpus"


def write(name, seeds):
    d = OUT / name
    d.mkdir(parents=True, exist_ok=True)
    for k, data in seeds.items():
        (d / k).write_bytes(data)


def dgram(data, ctrl=2):
    return bytes([ctrl]) + struct.pack("<H", len(data)) + data


def data_rows(rows, byte4=b"*"):
    out = b"DATA" + byte4
    for r, cols in rows:
        cols = list(cols) + [-999.0] * (8 - len(cols))
        out += struct.pack("<i8f", r, *cols)
    return out


def path_field(path, n):
    return path.encode() + b"\0" * (n - len(path))


# ------------------------------------------------------------ X-Plane (octo-fw side)
frame = data_rows([(1, [0, 0, 12.5]), (16, [0.1, -0.2, 0.3]), (17, [2.0, -4.5, 237.75, 259.25]),
                   (21, [1, 2, 3, 0.1, 0.2, 0.3]), (35, [2.6] * 8), (36, [0.04] * 8)])
version = b"RREF," + struct.pack("<if", 1, 120100.0)
v11 = b"RREF," + struct.pack("<if", 1, 110000.0)
write("xp_client", {
    "frame12": dgram(version) + dgram(frame) + dgram(frame.replace(struct.pack("<f", 12.5), struct.pack("<f", 12.6))),
    "frame11": dgram(v11) + dgram(frame),
    "rref3": dgram(b"RREF," + struct.pack("<ififif", 1, 120100.0, 7, 0.25, 8, -1.5)),
    "foreign": dgram(frame, ctrl=3),
    "unwanted_rows": dgram(version) + dgram(data_rows([(1, [0, 0, 1.0]), (3, [1]), (99, [2])])),
    "backwards": dgram(version) + dgram(frame) + dgram(data_rows([(1, [0, 0, 1.0])]), ctrl=200),
    "short": dgram(b"DAT") + dgram(b"DATA*" + b"\0" * 35),
})

# ------------------------------------------------------------ X-Plane (octo-sim side)
dsel = b"DSEL\0" + struct.pack("<8i", 1, 3, 4, 16, 17, 20, 21, 25)
dref = b"DREF\0" + struct.pack("<f", 0.5) + path_field("sim/flightmodel/engine/ENGN_thro_use[0]", 500)
override = b"DREF\0" + struct.pack("<f", 1.0) + path_field("sim/operation/override/override_throttles", 500)
rref = b"RREF\0" + struct.pack("<ii", 90, 7) + path_field("sim/flightmodel/position/Prad", 400)
data25 = b"DATA\0" + struct.pack("<i8f", 25, 0, .125, .25, .375, .5, .625, .75, 1.0)
ise4 = b"ISE4\0" + struct.pack("<i", 64) + b"127.0.0.1".ljust(16, b"\0") + b"49005".ljust(8, b"\0") + struct.pack("<i", 1)
cmnd = b"CMND\0sim/operation/pause_toggle\0"
write("sim_input", {
    "dsel": dgram(dsel) + dgram(b"USEL\0" + struct.pack("<2i", 3, 20)),
    "dref": dgram(override) + dgram(dref),
    "rref": dgram(rref) + dgram(b"RREF\0" + struct.pack("<ii", 0, 7) + path_field("sim/flightmodel/position/Prad", 400)),
    "data25": dgram(data25),
    "ise4": dgram(ise4),
    "cmnd": dgram(cmnd),
})

# ------------------------------------------------------------ MAVLink (octo-fw)
mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)


def payload(msg):
    b = msg.pack(mav)
    return b[10:10 + b[1]]


KIND = {"PARAM_SET": 0, "COMMAND_LONG": 1, "COMMAND_INT": 2, "PARAM_REQUEST_READ": 3,
        "PARAM_REQUEST_LIST": 4, "HEARTBEAT": 5, "MISSION_REQUEST_LIST": 6,
        "FILE_TRANSFER_PROTOCOL": 7, "RADIO_STATUS": 8, "STATUSTEXT": 9}


def rec(msg, flags=0):
    p = payload(msg)
    return bytes([KIND[msg.get_type()] | flags, len(p)]) + p


def frames(n):
    return b"".join(bytes([12, 0]) for _ in range(n))


def tick():
    return bytes([14, 1, 10])


def cl(cmd, *p):
    p = list(p) + [0.0] * (7 - len(p))
    return mavlink.MAVLink_command_long_message(1, 1, cmd, 0, *p)


hb = mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)
flight = (rec(hb) + frames(3) + rec(cl(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)) + frames(3)
          + rec(cl(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 2.0)) + frames(20)
          + rec(cl(mavlink.MAV_CMD_USER_1, 1)) + frames(20) + tick()
          + rec(mavlink.MAVLink_param_set_message(1, 1, b"VEH_KF", 30.0, 9)) + frames(2)
          + rec(cl(mavlink.MAV_CMD_NAV_LAND)) + frames(5))
write("mavlink", {
    "param_set": b"\0" + rec(mavlink.MAVLink_param_set_message(1, 1, b"VEH_KF", 27.0, 9))
    + rec(mavlink.MAVLink_param_set_message(1, 1, b"NAV_TOUCH_DOWN_S", 2.0, 9))
    + rec(mavlink.MAVLink_param_request_read_message(1, 1, b"VEH_KF", -1))
    + rec(mavlink.MAVLink_param_request_read_message(1, 1, b"", 3)),
    "param_list": b"\0" + rec(mavlink.MAVLink_param_request_list_message(1, 0)) + tick() * 8,
    "commands": b"\0" + rec(cl(mavlink.MAV_CMD_REQUEST_MESSAGE, 148))
    + rec(cl(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 31, 20000))
    + rec(cl(mavlink.MAV_CMD_PREFLIGHT_STORAGE, 1)) + rec(cl(mavlink.MAV_CMD_PREFLIGHT_STORAGE, 0))
    + rec(mavlink.MAVLink_command_int_message(1, 1, 0, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 0, 5.0))
    + rec(mavlink.MAVLink_mission_request_list_message(1, 1, 0))
    + rec(mavlink.MAVLink_file_transfer_protocol_message(0, 1, 1, bytes(251))),
    "flight": b"\0" + flight,
    "flight_signed": b"\1" + flight,
    "truncated": b"\0" + rec(mavlink.MAVLink_param_set_message(1, 1, b"VEH_KF", 27.0, 9), 0x80)
    + bytes([10, 12]) + bytes([0xFD, 9, 0, 0, 0, 255, 190, 0, 0, 0, 1, 2]),
    "other_sys": b"\0" + rec(mavlink.MAVLink_param_set_message(1, 1, b"VEH_KF", 27.0, 9), 0x20)
    + rec(mavlink.MAVLink_param_set_message(7, 1, b"VEH_KF", 27.0, 9)),
})

# ------------------------------------------------------------ experiments (fuzz_experiment.c)
def prm(name, value):
    return bytes([len(name)]) + name.encode() + struct.pack("<f", value)


def run(n=63, scale=128):  # (n + 1) x 64 frames of the simple plant
    return bytes([3 + 4 * n, 1, scale])


def one_frame(*floats):  # a frame whose rates (and what follows) are the floats
    b = struct.pack("<%df" % len(floats), *floats)
    return bytes([0, len(b)]) + b


write("experiment", {
    "rotor": bytes([0, 0]) + run() + run(),
    "rotor_short": bytes([0, 2]) + prm("ID_EXC_TIME", 2.0) + prm("ID_EXC_AMP", 0.08) + run(31, 140),
    "validation": bytes([1, 0]) + run() + run(),
    "inertia_x": bytes([2, 0]) + run() + one_frame(0.5, -0.2, 0.1) + run(),
    "inertia_z": bytes([4, 1]) + prm("ID_INR_TIME", 3.0) + run(31) + one_frame(0.0, 0.0, 3.0, 1e30),
    "sequence": bytes([5, 0]) + run() * 3,
})

# ------------------------------------------------------------ parameter file
write("params", {
    "plain": b"VEH_KF 28.0269\nVEH_KTAU 0.3869\nVEH_IXX 0.0628\n",
    "mavproxy": b"# saved\nVEH_KF           28.026900\nVEH_MASS,2.132\r\nATT_ZETA\t1.0 # c\n",
    "damaged": b"VEH_KF nan\nVEH_KTAU inf\nVEH_IXX 1e9\nNOPE 1\nVEH_IYY\nVEH_IZZ 1 2\nX\x01Y 3\n"
    + b"A" * 200 + b"\nNAV_TOUCH_DOWN_S 2",
})
print("seeds written under", OUT)
