"""Fault injection on the DATA stream (--drop, --burst, --delay-frames,
--duplicate, --reorder): seeded, measured frame by frame in lockstep.

Each lockstep tick the simulator sends the (faulted) DATA datagram, then the RREF
replies (never faulted). A subscription to sim/time/total_running_time_sec at
the frame rate therefore marks the end of every tick with the tick's time, and
the DATA seen before it are what the tick delivered."""

import pytest

import xplane_proto as xp
from test_sim_support import HOVER, RATE, SimUnderTest

TICKS = 300


def ticks(launch, port, *flags, n=TICKS, seed=5):
    """-> list of (tick index, [frame indices of the DATA delivered in that tick])."""
    s = SimUnderTest(launch, port, "--lockstep", "--lockstep-timeout", "5", "--seed", str(seed),
                     "--rows", "1", *flags)
    s.send(xp.encode_rref(int(RATE), 1, "sim/time/total_running_time_sec"))
    out, pending, started = [], [], False
    while len(out) < n:
        d = s.link.recv(2.0)
        assert d is not None, s.proc.stderr()
        if d[:4] == b"DATA":
            pending.append(round(xp.decode_data(d)[1][2] * RATE))
            continue
        (_, t), = xp.decode_rref(d)
        k = round(t * RATE)
        if k > 0:
            started = True
        if started:
            out.append((k, pending))
        pending = []
        s.command([HOVER] * 8)
    c = s.counters()
    return out, c


def test_no_faults_one_frame_per_tick(launch, port):
    out, c = ticks(launch, port, n=100)
    assert all(frames == [k] for k, frames in out)
    assert [k for k, _ in out] == list(range(1, 101))


def test_drop(launch, port):
    out, c = ticks(launch, port, "--drop", "0.3")
    lost = sum(1 for k, f in out if f == [])
    assert all(f in ([], [k]) for k, f in out)
    assert 0.18 * TICKS < lost < 0.42 * TICKS
    assert c["fault_dropped"] >= lost


def test_burst(launch, port):
    out, c = ticks(launch, port, "--burst", "7", "--burst-prob", "0.03")
    runs, run = [], 0
    for k, f in out:
        if f == []:
            run += 1
        else:
            if run:
                runs.append(run)
            run = 0
    assert runs, "no burst in 300 frames"
    assert all(r >= 7 for r in runs)
    assert all(f in ([], [k]) for k, f in out)


def test_delay_frames(launch, port):
    out, c = ticks(launch, port, "--delay-frames", "3", n=60)
    for k, f in out:
        assert f == ([k - 3] if k > 3 else []), (k, f)


def test_duplicate(launch, port):
    out, c = ticks(launch, port, "--duplicate", "0.25")
    dup = sum(1 for k, f in out if f == [k, k])
    assert all(f in ([k], [k, k]) for k, f in out)
    assert 0.12 * TICKS < dup < 0.38 * TICKS
    assert c["fault_duplicated"] >= dup


def test_reorder(launch, port):
    out, c = ticks(launch, port, "--reorder", "0.2")
    swapped = 0
    for i, (k, f) in enumerate(out):
        if f == []:
            # held back: delivered right after the next frame
            nk, nf = out[i + 1] if i + 1 < len(out) else (None, None)
            if nf is not None:
                assert nf[:2] == [nk, k], (k, nf)
                swapped += 1
    assert swapped > 0.08 * TICKS
    delivered = sorted(x for _, f in out for x in f)
    assert delivered == list(range(1, len(delivered) + 1)) or delivered[:-1] == list(range(1, len(delivered)))


def test_faults_are_reproducible(launch, port):
    a, _ = ticks(launch, port, "--drop", "0.2", "--duplicate", "0.2", "--reorder", "0.1", n=150)
    b, _ = ticks(launch, port, "--drop", "0.2", "--duplicate", "0.2", "--reorder", "0.1", n=150)
    c, _ = ticks(launch, port, "--drop", "0.2", "--duplicate", "0.2", "--reorder", "0.1", n=150, seed=6)
    assert a == b and a != c


def test_lockstep_does_not_wait_for_withheld_frames(launch, port):
    """A client that answers exactly the frames it receives never meets a timeout: frames the
    fault injector withheld (dropped, held back to be reordered) are advanced past at once, so a
    late answer can never count for a later frame."""
    s = SimUnderTest(launch, port, "--lockstep", "--lockstep-timeout", "30", "--seed", "9",
                     "--drop", "0.2", "--reorder", "0.1", rows=[1])
    f = s.start_lockstep([HOVER] * 8)
    last = f[1][2]
    s.command([HOVER] * 8)                 # answer frame 1
    answered = 1
    while answered < 300:
        t = s.next_data(timeout=5.0)[1][2]
        if t <= last:                      # the reordered older frame: no answer, as octo-fw does
            continue
        last = t
        s.command([HOVER] * 8)
        answered += 1
    c = s.counters()
    assert c["lockstep_timeouts"] == 0, c
    assert c["lockstep_withheld"] >= c["fault_dropped"] > 30, c
