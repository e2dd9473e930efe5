"""Processor-in-the-loop: the firmware image of the MPS2 AN386 board (Cortex-M4F) flies on
QEMU (docs/pil.md).

A short flight (take-off to 10 m, hold, land) through octo-gcs mission with the build
directory build/pil/, whose octo-fw starts QEMU and the host bridge; the framing of the
bridge and of the board (slip.c, built for the host with tests/pil/slip_test.c) against lost
bytes; and the bridge's dealing of the plant's bytes over the board's four receivers. Skipped only when the ARM toolchain or QEMU is missing
(`make arm` / `make pil` install them as root). The image is built here with make, as
`make pil-images` would (a no-op when it is up to date).
"""

import os
import shutil
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "firmware/hal/mps2/host"))
import octo_pil  # noqa: E402

MISSING = [t for t in ("qemu-system-arm", "arm-none-eabi-gcc") if shutil.which(t) is None]
needs_arm = pytest.mark.skipif(bool(MISSING), reason=f"{' and '.join(MISSING)} not installed "
                               "(make arm or make pil installs them as root)")


def test_slip_frames_survive_lost_and_changed_bytes():
    msgs = [bytes([i % 256 for i in range(n)]) + b"\xc0\xdb\xdc\xdd" for n in (5, 300, 41)]
    wire = b"".join(octo_pil.slip_frame(m) for m in msgs)
    r = octo_pil.SlipReader()
    assert r.feed(wire) == msgs and r.dropped == 0
    # a byte lost inside the second frame: only that frame is dropped
    f1, f2, f3 = (octo_pil.slip_frame(m) for m in msgs)
    r = octo_pil.SlipReader()
    got = r.feed(f1 + f2[:100] + f2[101:] + f3)
    assert got == [msgs[0], msgs[2]] and r.dropped == 1
    # a lost END merges two frames: both are dropped, the next one is whole
    r = octo_pil.SlipReader()
    got = r.feed(f1[:-1] + f2 + f3)
    assert got == [msgs[2]] and r.dropped == 1
    # an escape followed by a byte that is no escape code
    r = octo_pil.SlipReader()
    assert r.feed(b"\x01\xdb\x07\x02\xc0" + f3) == [msgs[2]] and r.dropped == 1
    # the CRC is zlib's CRC-32, little-endian after the message (the board's slip.c)
    assert octo_pil.slip_frame(b"abc")[3:7] == zlib.crc32(b"abc").to_bytes(4, "little")


def test_board_slip_decoder_survives_lost_changed_and_added_bytes(tmp_path):
    cc = os.environ.get("CC", "cc")
    exe = tmp_path / "slip_test"
    r = subprocess.run([cc, "-std=c11", "-O2", "-Wall", "-Wextra", "-Werror", "-Wconversion", "-Wshadow",
                        "-I", str(REPO / "firmware/hal/mps2"), "-o", str(exe),
                        str(REPO / "tests/pil/slip_test.c"), str(REPO / "firmware/hal/mps2/slip.c")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "all checks hold" in r.stdout, r.stdout + r.stderr


class _Sink:
    """A board UART's socket that takes everything."""

    def __init__(self):
        self.got = bytearray()

    def send(self, data):
        self.got += data
        return len(data)


def test_plant_lanes_deal_the_stream_in_turn():
    sinks = [_Sink() for _ in range(4)]
    lanes = octo_pil.Lanes([octo_pil.Outbox(s, 0) for s in sinks], 65536)
    msgs = [bytes(i % 256 for i in range(n)) for n in (5, 7, 300, 1)]
    frames = [octo_pil.slip_frame(m) for m in msgs]
    for f in frames:
        lanes.put(f)
    stream = b"".join(frames)
    # byte k of the stream on lane k mod 4: the board takes them back in the same turn
    for j, s in enumerate(sinks):
        assert bytes(s.got) == stream[j::4]
    merged = bytearray(len(stream))
    for j, s in enumerate(sinks):
        merged[j::4] = s.got
    assert octo_pil.SlipReader().feed(bytes(merged)) == msgs
    # lost bytes are taken out of the stream before it is dealt: the turn stays whole
    rng = octo_pil.random.Random(3)
    data = bytes(range(256)) * 4
    kept = octo_pil.lossy(data, 0.1, rng)
    assert 0 < len(kept) < len(data) and octo_pil.lossy(data, 0.0, rng) == data


def test_mavlink_splitter_cuts_whole_packets_and_skips_junk():
    v2 = bytes([0xFD, 3, 0, 0, 7, 1, 1, 0, 0, 0, 9, 9, 9, 0xAA, 0xBB])   # 12 + 3 bytes
    signed = bytes([0xFD, 1, 1, 0, 7, 1, 1, 0, 0, 0, 5, 0xAA, 0xBB]) + bytes(13)
    s = octo_pil.MavSplitter()
    out = s.feed(b"\x00\x11" + v2 + signed[:10])
    out += s.feed(signed[10:])
    assert out == [v2, signed] and s.junk == 2


def _make_image():
    r = subprocess.run(["make", "--no-print-directory", "build/pil/octo-fw"], cwd=REPO,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return REPO / "build/pil"


@needs_arm
@pytest.mark.timeout(240)
def test_pil_short_flight(tmp_path):
    bdir = _make_image()
    out = tmp_path / "out"
    r = subprocess.run([str(REPO / ".venv/bin/octo-gcs"), "mission", "--build-dir", str(bdir),
                        "--experiments", "none", "--no-plots", "--out", str(out)],
                       capture_output=True, text=True, timeout=200)
    log = (out / "octo-fw.log").read_text() if (out / "octo-fw.log").exists() else ""
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:] + log[-2000:]
    # the board flew, not a host octo-fw
    assert "MPS2 AN386 (Cortex-M4F), float build" in log
    assert "QEMU mps2-an386" in log
    for line in ("Mode TAKEOFF", "Mode HOLD", "Mode LAND", "Landed", "Mode DISARMED"):
        assert f"octo-fw: {line}" in log, line
    # no frame lost or spoilt on the links
    exit_line = [ln for ln in log.splitlines() if ln.startswith("octo-fw: exit:")][-1]
    assert " 0 frames dropped" in exit_line and " 0 dropped;" in exit_line, exit_line
    # the board's log reached fw.lcm: every mode of the flight, and the height held
    sys.path.insert(0, str(REPO / "build/gen/python"))
    sys.path.insert(0, str(REPO / "host_tools"))
    from octo import fw_frame_t
    from octo_gcs.logs import read_events
    frames = [fw_frame_t.decode(d) for (ch, _u, d) in read_events(str(out / "fw.lcm")) if ch == "OCTO_FW_FRAME"]
    # (IDLE may last no frame: take-off can follow arming before the next frame)
    modes = [f.mode for f in frames if f.mode != 1]
    seq = [m for i, m in enumerate(modes) if i == 0 or modes[i - 1] != m]
    assert seq[-4:] == [2, 3, 5, 0], seq
    ground = frames[0].pos_i[2]   # height in S_I is above the plant's local origin
    hold = [f.pos_i[2] - ground for f in frames if f.mode == 3]
    assert hold and abs(hold[-1] - 10.0) < 0.5, hold[-5:]
    assert [f.seq for f in frames] == list(range(frames[0].seq, frames[0].seq + len(frames)))
