"""octo-sim against the byte vectors and message rules of X-Plane's protocol (docs/xplane-protocol.md), in both
directions: vectors the sim receives are sent and their effect observed; what the
sim emits is decoded with the independent codec in xplane_proto.py."""

import hashlib
import math
import random
import struct
import time

import pytest

import xplane_proto as xp
from conftest import wait_until
from test_sim_support import HOVER, KF, KTAU, SimUnderTest, f32

# ---- byte vectors of X-Plane's messages (layouts in docs/xplane-protocol.md), verbatim
V_DATA_IN_25 = bytes.fromhex(
    "44415441 00 19000000 00000000 0000003e 0000803e 0000c03e 0000003f 0000203f 0000403f 0000803f")
V_DATA_IN_LEAVE = bytes.fromhex(
    "44415441 00 19000000 0000003f 0000003f 0000003f 0000003f 00c079c4 00c079c4 00c079c4 00c079c4")
V_DATA_OUT = bytes.fromhex(
    "44415441 2a 10000000 0000c03f 000010c0 00002041 00c079c4 00c079c4 00c079c4 00c079c4 00c079c4"
    " 11000000 00000040 000090c0 00c06d43 00a08143 00c079c4 00c079c4 00c079c4 00c079c4")
THRO0 = b"sim/flightmodel/engine/ENGN_thro_use[0]"
V_DREF = bytes.fromhex("44524546 00 0000003f") + THRO0 + b"\x00" * 461
V_DREF_30 = bytes.fromhex("44524546 30 0000003f") + THRO0 + b"\x00" * 461
V_DREF_SP = bytes.fromhex("44524546 00 0000003f") + THRO0 + b"\x00" + b" " * 460
V_RREF_REQ = bytes.fromhex("52524546 00 5a000000 07000000") + b"sim/flightmodel/position/Prad".ljust(400, b"\x00")
V_RREF_1 = bytes.fromhex("52524546 2c 07000000 0000803e")
V_RREF_3 = bytes.fromhex("52524546 2c 01000000 0092ea47 07000000 0000803e 08000000 0000c0bf")
V_DSEL = bytes.fromhex("4453454c 00 01000000 03000000 04000000 10000000 11000000 14000000 15000000 19000000")

SHA = {
    "data25": "779eea6301202cf5df6424bd30049e585a9d7754d6d95a6dce093c2ca58be3bb",
    "dref": "f2b550d88c6ae1030a7d2516af96a57df4fd3fc86d704b9a5c019d347063f4c2",
    "dref30": "877173876903083e564f0828cc38dcaba7affd3ff237751bce9f56fb0c9660af",
    "drefsp": "5959cf00d489016f55e1e422f36e2089d66a6b5581cb8c3fdf6a49293082175c",
    "rref": "e624d430510561d97358deb2d497421459c3dd1e1bba7952481d07668a6a2a3b",
}


def sha(b):
    return hashlib.sha256(b).hexdigest()


# ------------------------------------------------------------------ the codec itself
def test_vectors_are_the_documented_ones():
    assert len(V_DATA_IN_25) == 41 and sha(V_DATA_IN_25) == SHA["data25"]
    assert sha(V_DREF) == SHA["dref"] and sha(V_DREF_30) == SHA["dref30"] and sha(V_DREF_SP) == SHA["drefsp"]
    assert len(V_RREF_REQ) == 413 and sha(V_RREF_REQ) == SHA["rref"]
    assert len(V_DATA_OUT) == 77 and len(V_DSEL) == 37


def test_codec_encodes_and_decodes_every_vector():
    assert xp.encode_data({25: [0, .125, .25, .375, .5, .625, .75, 1.0]}) == V_DATA_IN_25
    assert xp.encode_data({25: [0.5] * 4}) == V_DATA_IN_LEAVE
    assert xp.encode_data([(16, [1.5, -2.25, 10.0]), (17, [2.0, -4.5, 237.75, 259.25])],
                          byte4=xp.DATA_OUT_BYTE4) == V_DATA_OUT
    rows = xp.decode_data_list(V_DATA_OUT)
    assert [r for r, _ in rows] == [16, 17]
    assert rows[0][1][:3] == (1.5, -2.25, 10.0) and rows[0][1][3:] == (-999.0,) * 5
    assert rows[1][1][:4] == (2.0, -4.5, 237.75, 259.25)
    assert xp.encode_dref(THRO0.decode(), 0.5) == V_DREF
    assert xp.encode_dref(THRO0.decode(), 0.5, byte4=0x30) == V_DREF_30
    assert xp.encode_dref(THRO0.decode(), 0.5, pad=b" ") == V_DREF_SP
    for v in (V_DREF, V_DREF_30, V_DREF_SP):
        assert xp.decode_dref(v) == (THRO0.decode(), 0.5)
    assert xp.encode_rref(90, 7, "sim/flightmodel/position/Prad") == V_RREF_REQ
    assert xp.decode_rref_request(V_RREF_REQ) == (90, 7, "sim/flightmodel/position/Prad")
    assert xp.decode_rref(V_RREF_1) == [(7, 0.25)]
    assert xp.decode_rref(V_RREF_3) == [(1, 120100.0), (7, 0.25), (8, -1.5)]
    assert xp.encode_rref_reply([(7, 0.25)]) == [V_RREF_1]
    assert xp.encode_rref_reply([(1, 120100.0), (7, 0.25), (8, -1.5)]) == [V_RREF_3]
    assert xp.encode_dsel([1, 3, 4, 16, 17, 20, 21, 25]) == V_DSEL
    assert len(xp.encode_ise4("127.0.0.1", 49005)) == 37
    for bad in (b"DAT", b"DATA*" + b"\x00" * 35, b"RREF," + b"\x00" * 7):
        with pytest.raises(xp.ProtocolError):
            (xp.decode_rref if bad.startswith(b"RREF") else xp.decode_data)(bad)


# ------------------------------------------------------------------ sim as emitter
def test_dsel_vector_gives_rows_in_ascending_order(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--ideal")
    s.send(V_DSEL)
    raw = s.link.recv_type("DATA")
    assert raw is not None
    assert raw[:5] == b"DATA*" and len(raw) == 5 + 36 * 8
    rows = xp.decode_data_list(raw)
    assert [r for r, _ in rows] == [1, 3, 4, 16, 17, 20, 21, 25]
    d = dict(rows)
    assert d[1][2] == 0.0                                     # mission time, still at 0
    assert d[4][4] == pytest.approx(1.0)                      # g normal, landed
    assert d[17][:2] == (0.0, 0.0) and d[17][2] == 0.0        # level, heading north
    assert d[25] == (0.0,) * 8
    # columns that carry nothing are -999, bytes 00 c0 79 c4
    off = {r: 5 + 36 * k + 4 for k, (r, _) in enumerate(rows)}
    for row, unused in ((16, range(3, 8)), (17, range(4, 8)), (20, range(4, 8)), (4, (1, 3, 7))):
        for c in unused:
            assert raw[off[row] + 4 * c: off[row] + 4 * c + 4] == xp.NO_DATA_BYTES, (row, c)


def test_data_output_format_matches_the_rows_16_17_vector(launch, port):
    """The live datagram for rows 16 and 17 has exactly the vector's layout."""
    s = SimUnderTest(launch, port, "--ideal", "--rows", "17,16")
    raw = s.link.recv_type("DATA")
    assert len(raw) == len(V_DATA_OUT) == 77
    assert raw[:5] == V_DATA_OUT[:5]                          # DATA*
    assert raw[5:9] == V_DATA_OUT[5:9] and raw[41:45] == V_DATA_OUT[41:45]  # row 16, then 17
    assert raw[5 + 4 + 12:41] == V_DATA_OUT[5 + 4 + 12:41]    # row 16 c4..c8 = -999
    assert raw[41 + 4 + 16:] == V_DATA_OUT[41 + 4 + 16:]      # row 17 c5..c8 = -999


def test_no_data_until_selected_and_usel(launch, port):
    s = SimUnderTest(launch, port, "--rate", "200")
    assert s.link.recv(0.3) is None                           # nothing selected: silence
    s.send(bytes.fromhex("4453454c 00 11000000 00000000 00000000 11000000 10000000 00000000 00000000 00000000"))
    d = s.next_data()
    assert sorted(d) == [16, 17]                              # zeros and duplicates tolerated
    s.send(xp.encode_usel([16, 17]))
    time.sleep(0.1)
    s.link.drain()
    assert s.link.recv(0.3) is None


# ------------------------------------------------------------------ sim as receiver
def test_data_in_row25_vector_drives_the_rotors(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--ideal", "--rows", "1,25,26,35")
    s.next_data()
    s.link.drain()
    s.send(V_DATA_IN_25)
    f = s.next_data()
    while f[1][2] == 0.0:
        f = s.next_data()
    want = (0.0, .125, .25, .375, .5, .625, .75, 1.0)
    assert f[25] == want
    assert f[26] == want                                      # ideal: no lag
    for j in range(8):
        assert f[35][j] == pytest.approx(KF * want[j] / xp.N_PER_LB, rel=1e-6)


def test_data_in_minus_999_leaves_engines_alone(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--ideal", "--rows", "1,25")
    s.start_lockstep([0.25] * 8)
    s.send(V_DATA_IN_LEAVE)
    f = s.next_data()
    assert f[25] == (0.5,) * 4 + (0.25,) * 4


@pytest.mark.parametrize("vector", [V_DREF, V_DREF_30, V_DREF_SP], ids=["nul", "ascii0", "spaces"])
def test_dref_vectors_are_accepted(launch, port, vector):
    s = SimUnderTest(launch, port, "--ideal", "--rate", "200", "--rows", "25,26")
    s.send(xp.encode_dref(xp.OVERRIDE_THROTTLES, 1.0))
    s.send(xp.encode_dref(xp.THRO_USE + "[0]", 0.125))
    assert wait_until(lambda: s.next_data()[25][0] == 0.125, timeout=3)
    s.send(vector)
    assert wait_until(lambda: s.next_data()[25][0] == 0.5, timeout=3)
    assert s.next_data()[26][0] == 0.5


def test_dref_throttles_need_the_override(launch, port):
    s = SimUnderTest(launch, port, "--ideal", "--rate", "200", "--rows", "25")
    s.send(V_DREF)
    time.sleep(0.1)
    s.link.drain()
    assert s.next_data()[25][0] == 0.0                        # ENGN_thro drives: still 0
    s.send(xp.encode_dref(xp.OVERRIDE_THROTTLES, 1.0))
    assert wait_until(lambda: s.next_data()[25][0] == 0.5, timeout=3)
    s.send(xp.encode_dref(xp.OVERRIDE_THROTTLES, 0.0))
    assert wait_until(lambda: s.next_data()[25][0] == 0.0, timeout=3)


def test_rref_vector_and_replies(launch, port):
    s = SimUnderTest(launch, port, "--ideal", "--rate", "90")
    s.send(V_RREF_REQ)
    r = s.link.recv_type("RREF")
    assert r is not None and r[:5] == b"RREF," and len(r) == 13
    assert xp.decode_rref(r) == [(7, 0.0)]                    # landed: P = 0
    # three subscriptions -> one reply datagram of 29 bytes, records as the vector
    s.send(xp.encode_rref(90, 1, xp.VERSION_DATAREF))
    s.send(xp.encode_rref(90, 8, "sim/flightmodel/position/local_y"))
    def three():
        d = s.link.recv_type("RREF")
        return d if d is not None and len(d) == 29 else None
    r3 = wait_until(three, timeout=3)
    assert r3
    recs = dict(xp.decode_rref(r3))
    assert recs == {7: 0.0, 1: 120100.0, 8: 640.0}      # local_y: the field's elevation MSL
    assert bytes.fromhex("01000000 0092ea47") in r3       # (1, 120100.0) exactly as in the vector
    # rate 0 stops each subscription
    for idx, path in ((7, "sim/flightmodel/position/Prad"), (1, xp.VERSION_DATAREF),
                      (8, "sim/flightmodel/position/local_y")):
        s.send(xp.encode_rref(0, idx, path))
    time.sleep(0.1)
    s.link.drain()
    assert s.link.recv_type("RREF", timeout=0.3) is None


def test_rref_rate_and_183_record_limit(launch, port):
    s = SimUnderTest(launch, port, "--ideal", "--rate", "100")
    for i in range(200):
        s.send(xp.encode_rref(100, 1000 + i, f"{xp.THRO_USE}[{i % 8}]"))
    s.send(xp.encode_rref(10, 5, xp.VERSION_DATAREF))         # 10 Hz among 100 Hz
    time.sleep(0.3)
    s.link.drain()
    sizes, version_seen, t0 = [], 0, time.monotonic()
    while time.monotonic() - t0 < 1.0:
        d = s.link.recv_type("RREF", timeout=1)
        recs = xp.decode_rref(d)
        sizes.append(len(recs))
        version_seen += sum(1 for k, _ in recs if k == 5)
    assert max(sizes) == 183 and set(sizes) <= {183, 17, 18}
    assert 6 <= version_seen <= 14                            # ~10 per second


def test_version_11_personality(launch, port):
    s = SimUnderTest(launch, port, "--xplane-version", "11", "--rate", "90")
    s.send(xp.encode_rref(1, 3, xp.VERSION_DATAREF))
    v = xp.decode_rref(s.link.recv_type("RREF"))[0][1]
    assert 110000 <= v < 120000


def test_row16_differs_between_11_and_12(launch, port):
    frames = {}
    for version in (11, 12):
        s = SimUnderTest(launch, port, "--lockstep", "--ideal", "--xplane-version", str(version),
                         "--rows", "1,16")
        u = [HOVER * 1.3 + (0.02 if j in (0, 2, 3, 4) else 0.0) for j in range(8)]  # roll, pitch, yaw
        f = s.start_lockstep(u)
        for _ in range(30):
            f = s.step(u)
        frames[version] = f[16]
        s.stop()
    p11, q11, r11 = xp.row16_pqr(frames[11], 11)
    p12, q12, r12 = xp.row16_pqr(frames[12], 12)
    assert abs(p11) > 0.01 and abs(q11) > 0.01 and abs(r11) > 0.001
    assert frames[11][0] == q11 and frames[11][1] == p11     # 11: Q, P, R in rad/s
    for a, b in ((p11, p12), (q11, q12), (r11, r12)):
        assert b == pytest.approx(a, rel=1e-5, abs=1e-7)      # 12: P, Q, R in deg/s


def test_ise4_sets_the_data_output_target(launch, port):
    s = SimUnderTest(launch, port, "--rate", "200", "--rows", "17")
    assert s.next_data()
    with xp.Link(s.xp_port, port=port()) as other:
        other.send(xp.encode_ise4("127.0.0.1", other.port, 1))
        assert other.recv_data(2.0) is not None
        time.sleep(0.05)
        s.link.drain()
        assert s.link.recv(0.2) is None
        other.send(xp.encode_ise4("127.0.0.1", other.port, 0))     # disable
        time.sleep(0.05)
        other.drain()
        assert other.recv(0.2) is None


# ------------------------------------------------------------------ hostile input
HOSTILE = [
    (b"", "rx_short"), (b"DAT", "rx_short"), (b"XXXX\x00abc", "rx_unknown_type"),
    (b"DATA\x00" + b"\x00" * 35, "rx_bad_size"),                                  # 40 bytes
    (b"DATA\x00", "rx_bad_size"),
    (xp.encode_data({25: [float("nan")] + [0.1] * 7}), "rx_bad_value"),
    (xp.encode_data({25: [float("inf")] + [0.1] * 7}), "rx_bad_value"),
    (xp.encode_data({25: [1.5, -0.5] + [0.1] * 6}), "rx_clamped"),
    (xp.encode_data({3: [1] * 8}), "rx_ignored_row"),
    (V_DREF[:-1], "rx_bad_size"), (V_DREF + b"\x00", "rx_bad_size"),
    (b"DREF\x00" + struct.pack("<f", 0.5) + b"A" * 500, "rx_unterminated"),
    (b"DREF\x00" + struct.pack("<f", float("nan")) + THRO0.ljust(500, b"\x00"), "rx_bad_value"),
    (xp.encode_dref("sim/cockpit/nothing", 1.0), "rx_ignored_dref"),
    (xp.encode_dref(xp.THRO_USE + "[x]", 1.0), "rx_ignored_dref"),
    (V_RREF_REQ[:-3], "rx_bad_size"),
    (b"RREF\x00" + struct.pack("<ii", 10, 1) + b"B" * 400, "rx_unterminated"),
    (b"RREF\x00" + struct.pack("<ii", -5, 1) + b"sim/x".ljust(400, b"\x00"), "rx_bad_value"),
    (b"DSEL\x00\x01\x00\x00", "rx_bad_size"),
    (xp.encode_dsel([-3, 100000]), "rx_bad_row"),
    (xp.encode_cmnd("sim/none/command"), "rx_cmnd"),
    (b"CMND\x00no-nul", "rx_cmnd"),             # the path may end with the datagram, as in X-Plane
    (b"CMND\x00", "rx_unterminated"),           # empty
    (b"CMND\x00bad\x01path", "rx_unterminated"),  # not printable
    (xp.encode_ise4("127.0.0.1", 49005, index=3), "rx_bad_ise4"),
    (xp.encode_ise4("not-an-ip", 49005), "rx_bad_ise4"),
    (b"ISE4\x00\x40\x00\x00\x00", "rx_bad_size"),
    (b"DATA\x00" + b"\xff" * 9000, "rx_bad_size"),                                # truncated
]


def test_every_malformed_datagram_is_dropped_and_counted(launch, port):
    s = SimUnderTest(launch, port, "--ideal", "--rate", "200", "--rows", "25")
    s.send(xp.encode_data({25: [0.1] * 8}))
    assert wait_until(lambda: s.next_data()[25][0] == f32(0.1), timeout=3)
    expected = {}
    for dgram, counter in HOSTILE:
        s.send(dgram)
        expected[counter] = expected.get(counter, 0) + 1
    time.sleep(0.2)
    s.link.drain()
    f = s.next_data()
    assert f[25][0] == 1.0 and f[25][1] == 0.0                  # the clamped record applied
    assert f[25][2] == f32(0.1)
    assert s.proc.alive()
    c = s.counters()
    for counter, n in expected.items():
        assert c[counter] >= n, (counter, c)
    assert c["rx_datagrams"] == len(HOSTILE) + 1


def test_random_datagrams_never_crash(launch, port):
    s = SimUnderTest(launch, port, "--rate", "200", "--rows", "1,16,17,25")
    rng = random.Random(3)
    valid = [V_DATA_IN_25, V_DATA_IN_LEAVE, V_DREF, V_RREF_REQ, V_DSEL, xp.encode_usel([1]),
             xp.encode_cmnd("sim/x"), xp.encode_ise4("127.0.0.1", s.link.port, 1)]
    for i in range(3000):
        base = bytearray(rng.choice(valid))
        kind = rng.random()
        if kind < 0.3:
            base = base[:rng.randrange(len(base) + 1)]
        elif kind < 0.6:
            for _ in range(rng.randint(1, 8)):
                if base:
                    base[rng.randrange(len(base))] = rng.randrange(256)
        elif kind < 0.8:
            base = base[:4] + bytes(rng.randrange(256) for _ in range(rng.randrange(600)))
        else:
            base = bytes(rng.randrange(256) for _ in range(rng.randrange(64)))
        s.send(bytes(base))
        if i % 500 == 0:
            time.sleep(0.01)
    time.sleep(0.2)
    assert s.proc.alive()
    s.send(xp.encode_ise4("127.0.0.1", s.link.port, 1))
    s.send(xp.encode_dsel([17]))
    s.link.drain()
    assert s.link.recv_type("DATA", 2.0) is not None
    c = s.counters()
    assert c["rx_datagrams"] >= 3000


RREF_PATHS = {
    10: "sim/flightmodel/position/Prad", 11: "sim/flightmodel/position/Qrad",
    12: "sim/flightmodel/position/Rrad", 13: "sim/flightmodel/position/theta",
    14: "sim/flightmodel/position/phi", 15: "sim/flightmodel/position/psi",
    16: "sim/flightmodel/position/q[0]", 17: "sim/flightmodel/position/q[1]",
    18: "sim/flightmodel/position/q[2]", 19: "sim/flightmodel/position/q[3]",
    20: "sim/flightmodel/position/local_x", 21: "sim/flightmodel/position/local_y",
    22: "sim/flightmodel/position/local_z", 23: "sim/flightmodel/position/local_vx",
    24: "sim/flightmodel/position/local_vy", 25: "sim/flightmodel/position/local_vz",
    26: "sim/flightmodel/engine/POINT_thrust[2]", 27: "sim/flightmodel/engine/ENGN_TRQ[2]",
    28: "sim/flightmodel/engine/ENGN_thro_use[2]", 29: "sim/time/total_running_time_sec",
    30: "sim/flightmodel/position/P", 31: "sim/operation/override/override_throttles",
}


def test_rref_values_agree_with_the_data_rows(launch, port):
    """Same frame, two channels: every subscribed dataref equals its DATA row value."""
    s = SimUnderTest(launch, port, "--lockstep", "--rows", "1,16,17,21,25,35,36")
    for idx, path in RREF_PATHS.items():
        s.send(xp.encode_rref(90, idx, path))
    s.next_data()
    s.link.drain()
    u = [HOVER * 1.2 + (0.01 if j in (0, 1, 7) else 0.0) for j in range(8)]
    s.command(u)
    checked = 0
    while checked < 40:
        d = s.link.recv_type("DATA")
        r = s.link.recv_type("RREF")
        f, v = xp.decode_data(d), dict(xp.decode_rref(r))
        if v[29] == 0.0:
            continue                                          # pre-start repetition
        assert v[29] == f[1][2]
        P, Q, R = xp.row16_pqr(f[16], 12)
        assert (v[10], v[11], v[12]) == pytest.approx((P, Q, R), rel=1e-5, abs=1e-6)
        assert v[30] == pytest.approx(f[16][0], rel=1e-5, abs=1e-5)
        assert (v[13], v[14], v[15]) == (f[17][0], f[17][1], f[17][2])
        assert (v[20], v[21], v[22], v[23], v[24], v[25]) == f[21][:6]
        assert v[26] == pytest.approx(f[35][2] * xp.N_PER_LB, rel=1e-5)
        assert v[27] == pytest.approx(f[36][2] * xp.NM_PER_FTLB, rel=1e-5)
        assert v[28] == f[25][2] == f32(u[2]) and v[31] == 0.0
        # q from the half angles of (heading, pitch, roll)
        ps, th, ph = (math.radians(a) / 2 for a in (f[17][2], f[17][0], f[17][1]))
        qw = math.cos(ph) * math.cos(th) * math.cos(ps) + math.sin(ph) * math.sin(th) * math.sin(ps)
        qx = math.sin(ph) * math.cos(th) * math.cos(ps) - math.cos(ph) * math.sin(th) * math.sin(ps)
        sign = 1.0 if qw * v[16] >= 0 else -1.0                # q and -q: the same rotation
        assert (v[16], v[17]) == pytest.approx((sign * qw, sign * qx), abs=1e-5)
        assert v[16] ** 2 + v[17] ** 2 + v[18] ** 2 + v[19] ** 2 == pytest.approx(1.0, abs=1e-5)
        s.command(u)
        checked += 1
