"""octo-fw's plant time line from X-Plane's float32 mission time (xp_client's xp_clock),
against a fake X-Plane that sends row 1 as X-Plane does (float32): frames are counted from
the stamps where their resolution tells them apart, one per datagram where it does not, and
the app's step is whole frame periods, never a difference of two stamps."""

import struct

import pytest

import xplane_proto as xp
from test_fw_rig import read_log
from test_fw_xplane import frame, start

P = 1 / 90


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def fly_stamps(launch, port, tmp_path, stamps):
    """Sends one DATA frame per stamp (None: nothing, a lost frame); returns the firmware's
    log frames of those datagrams."""
    rig, fake = start(launch, port, tmp_path)
    fake.pump(0.2)
    _, index, _ = xp.decode_rref_request(fake.of_type(b"RREF")[0])
    for d in xp.encode_rref_reply([(index, 120100.0)]):
        fake.send(d)
    fake.pump(0.05)
    sent = 0
    for t in stamps:
        if t is None:
            continue
        fake.send(frame(t, 12))
        sent += 1
        fake.pump(0.004)
    fake.pump(0.1)
    rig.fw.stop()
    log = read_log(rig.fw_log, "OCTO_FW_FRAME")
    assert len(log) >= sent
    return log[-sent:]


def test_fine_stamps_count_lost_frames_and_tell_duplicates(launch, port, tmp_path):
    # at 40,000 s the stamp's resolution is 3.9 ms: a lost frame and a duplicate are told
    base = 40000.0
    n = list(range(200))
    stamps = [base + k * P for k in n]
    stamps[120] = None                       # lost
    stamps.insert(160, stamps[159])          # a duplicate of frame 159
    log = fly_stamps(launch, port, tmp_path, stamps)
    assert log[0].t == pytest.approx(base, abs=1e-6)
    stepped = [r for r in log if r.stepped]
    assert len(stepped) == len(log) - 1 and not log[159].stepped   # the duplicate (frame 159 again)
    # plant time: frame k at k periods, the lost frame counted
    times = [r.t - base for r in stepped]
    want = [k * P for k in n if k != 120]
    assert max(abs(a - b) for a, b in zip(times, want)) < 2e-6
    dts = [r.dt for r in stepped[1:]]
    gap = dts[119]                            # the step onto frame 121
    assert gap == pytest.approx(2 * P, rel=1e-4)
    assert all(d == pytest.approx(P, rel=1e-4) for i, d in enumerate(dts) if i != 119)


@pytest.mark.parametrize("base", (100000.0, 1e6))
def test_coarse_stamps_count_each_datagram(launch, port, tmp_path, base):
    # at 1e5 s (7.8 ms) a gap of two frames cannot be told from one; at 1e6 s (62.5 ms)
    # consecutive frames often share a stamp: each new datagram is one frame, the step is
    # one period, the time line runs on frame by frame
    stamps = [base + k * P for k in range(200)]
    assert len({f32(s) for s in stamps}) < 200 or base < 1e6
    log = fly_stamps(launch, port, tmp_path, stamps)
    assert all(r.stepped for r in log)
    times = [r.t - log[0].t for r in log]
    assert max(abs(t - k * P) for k, t in enumerate(times)) < 2e-6
    assert all(r.dt == pytest.approx(P, rel=1e-4) for r in log[1:])
