#!/usr/bin/env python3
"""octo_pil.py - octo-fw on an emulated MPS2 AN386 board: QEMU and the host bridge.

Takes octo-fw's command line (--xplane, --xp-listen, --mavlink-listen, --gcs, --params,
--lcm), so that a build directory whose octo-fw runs this (make pil-images writes it) serves
octo-gcs mission and the tests as the host octo-fw does. It starts qemu-system-arm -M
mps2-an386 with the image and joins the board's three UARTs, each a QEMU chardev on a UNIX
socket, to the world (docs/pil.md):

  UART0  plant   X-Plane datagrams, one per SLIP frame with a CRC-32, <-> octo-sim's UDP;
                 towards the board the frames' bytes are dealt in turn to four lanes, the
                 receivers of UART0, UART2, UART3 and UART4 (QEMU moves one byte per UART
                 at a time, so four receivers take four bytes at a time)
  UART1  ground  MAVLink 2 bytes; cut into whole packets, one per UDP datagram, <-> the
                 ground station (learned from the last datagram, as octo-fw does)
  UART2  log     the firmware log (SLIP frames with a CRC-32) -> the LCM event log of --lcm

The board's console (semihosting) is this program's stdout. SIGTERM or SIGINT stop QEMU and
end the run; should QEMU stop by itself (a fault: exit status 126), its status is returned.

OCTO_PIL_QEMU_ARGS (environment): further QEMU options, split at spaces.

OCTO_PIL_DROP=P (environment, 0 <= P < 1) drops each byte towards the board (plant and
ground) with probability P before it is framed onto the UARTs, to test the links' recovery.

OCTO_PIL_COUNTS=FILE (environment) loads tests/arm's instruction-counting plugin (--plugin) on
the step markers board_step_begin/board_step_end: FILE gets one line per control step,
"octo-count: region N: M instructions", in the order of the log's OCTO_FW_FRAME records.
"""

import argparse
import os
import random
import selectors
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import zlib

END, ESC, ESC_END, ESC_ESC = 0xC0, 0xDB, 0xDC, 0xDD
PROG = "octo-fw"


def say(text):
    print(f"{PROG}: {text}", flush=True)


def fail(text, code=1):
    print(f"{PROG}: {text}", file=sys.stderr, flush=True)
    sys.exit(code)


# ---------------------------------------------------------------- framing
def slip_frame(payload):
    """One SLIP frame of payload and its CRC-32 (little-endian)."""
    body = payload + zlib.crc32(payload).to_bytes(4, "little")
    body = body.replace(bytes([ESC]), bytes([ESC, ESC_ESC])).replace(bytes([END]), bytes([ESC, ESC_END]))
    return body + bytes([END])


class SlipReader:
    """Bytes in, good frames out; a frame with a bad escape or CRC is dropped and counted."""

    def __init__(self):
        self.buf = b""
        self.frames = self.dropped = 0

    def feed(self, data):
        self.buf += data
        *parts, self.buf = self.buf.split(bytes([END]))
        out = []
        for p in parts:
            if not p:
                continue
            q = p.replace(bytes([ESC, ESC_END]), bytes([END])).replace(bytes([ESC, ESC_ESC]), bytes([ESC]))
            # an ESC left over was followed by neither ESC_END nor ESC_ESC (a changed byte)
            if len(q) < 5 or q.count(bytes([ESC])) != p.count(bytes([ESC, ESC_ESC])) \
                    or zlib.crc32(q[:-4]) != int.from_bytes(q[-4:], "little"):
                self.dropped += 1
                continue
            self.frames += 1
            out.append(q[:-4])
        return out


class MavSplitter:
    """MAVLink (v2 0xFD, v1 0xFE) bytes in, whole packets out by their length fields. The
    ground station checks each packet; bytes outside packets are skipped and counted."""

    def __init__(self):
        self.buf = bytearray()
        self.junk = 0

    def feed(self, data):
        self.buf += data
        out = []
        while self.buf:
            if self.buf[0] not in (0xFD, 0xFE):
                k = 1
                while k < len(self.buf) and self.buf[k] not in (0xFD, 0xFE):
                    k += 1
                self.junk += k
                del self.buf[:k]
                continue
            if len(self.buf) < 3:
                break
            n = 8 + self.buf[1] if self.buf[0] == 0xFE else 12 + self.buf[1] + (13 if self.buf[2] & 1 else 0)
            if len(self.buf) < n:
                break
            out.append(bytes(self.buf[:n]))
            del self.buf[:n]
        return out


# ---------------------------------------------------------------- log
class LogWriter:
    """The board's log records into an LCM event log (channels as octo-fw's)."""

    def __init__(self, url, gen_python):
        self.log = None
        if not url:
            return
        if not url.startswith("file://"):
            fail(f"--lcm: only file://PATH on this platform, not {url}", 2)
        sys.path.insert(0, gen_python)
        import lcm
        from octo import fw_event_t, fw_frame_t, fw_id_result_t
        self.event_t = fw_event_t
        self.fp_frame = fw_frame_t._get_packed_fingerprint()
        self.fp_id = fw_id_result_t._get_packed_fingerprint()
        path = url[len("file://"):].split("?", 1)[0]
        try:
            self.log = lcm.EventLog(path, "w", overwrite=True)
        except (IOError, OSError) as e:
            fail(f"--lcm: cannot create log {path}: {e}")
        self.bad = 0

    def record(self, rec):
        if self.log is None or not rec:
            return
        kind, body = rec[0], rec[1:]
        if len(body) < 8:
            self.bad += 1
            return
        utime = int.from_bytes(body[:8], "big", signed=True)
        if kind == ord("F"):
            self.log.write_event(utime, "OCTO_FW_FRAME", self.fp_frame + body)
        elif kind == ord("I"):
            self.log.write_event(utime, "OCTO_FW_ID_RESULT", self.fp_id + body)
        elif kind == ord("E") and len(body) >= 9:
            m = self.event_t()
            m.utime = utime
            m.severity = int.from_bytes(body[8:9], "big", signed=True)
            m.text = body[9:].decode("utf-8", errors="replace")
            self.log.write_event(utime, "OCTO_FW_EVENT", m.encode())
        else:
            self.bad += 1

    def close(self):
        if self.log is not None:
            self.log.close()
            self.log = None


# ---------------------------------------------------------------- command line
def hostport(flag, text):
    host, sep, port = text.rpartition(":")
    try:
        if not sep or not host:
            raise ValueError
        return socket.gethostbyname(host), int(port)
    except (ValueError, OSError):
        fail(f"{flag}: '{text}' is not HOST:PORT", 2)


def parse(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    p.add_argument("--xplane", default="127.0.0.1:49000")
    p.add_argument("--xp-listen", type=int, default=49005)
    p.add_argument("--mavlink-listen", type=int, default=14580)
    p.add_argument("--gcs", default="127.0.0.1:14550")
    p.add_argument("--params", help="accepted for octo-fw's command line: the board keeps its "
                   "parameters in its own RAM sector for the run")
    p.add_argument("--lcm", help="file://PATH: the board's log as an LCM event log")
    p.add_argument("--actuation", choices=("data25",), default="data25",
                   help="the board actuates with one DATA row 25 datagram per frame")
    p.add_argument("--elf", required=True, help="the board image")
    p.add_argument("--plugin", help="tests/arm's instruction-counting plugin (OCTO_PIL_COUNTS)")
    p.add_argument("--gen-python", default="", help="the generated LCM Python types")
    p.add_argument("--qemu", default="qemu-system-arm")
    p.add_argument("--icount", default="3", metavar="SHIFT",
                   help="QEMU's -icount shift=SHIFT: each instruction advances the board's clock "
                   "2^SHIFT ns, so a host that pauses the running board does not age it; a board "
                   "asleep in WFI sees the host's time pass (sleep=on). 'off': the host's clock")
    return p.parse_args(argv)


def udp_bind(port, what):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.bind(("0.0.0.0", port))
    except OSError as e:
        fail(f"cannot bind {what} port {port}: {e.strerror}")
    s.setblocking(False)
    return s


def symbol(elf, name):
    nm = shutil.which("arm-none-eabi-nm") or "arm-none-eabi-nm"
    out = subprocess.run([nm, elf], capture_output=True, text=True, check=True).stdout
    for line in out.splitlines():
        f = line.split()
        if len(f) == 3 and f[2] == name:
            return "0x" + f[0]
    fail(f"{elf} has no symbol {name}")


class Outbox:
    """Bytes for one UART socket, sent as QEMU takes them (never blocking: the board may be
    waiting for this program to read its own output). Beyond cap bytes waiting, a new message
    is dropped whole and counted, as a datagram to a busy receiver is."""

    def __init__(self, sock, cap):
        self.sock, self.cap = sock, cap
        self.buf = bytearray()
        self.dropped = 0

    def put(self, data):
        if len(self.buf) > self.cap:
            self.dropped += 1
            return
        self.buf += data
        self.flush()

    def flush(self):
        if self.buf:
            try:
                del self.buf[:self.sock.send(self.buf)]
            except BlockingIOError:
                pass


class Lanes:
    """The plant's byte stream towards the board, dealt byte by byte in turn to the lanes'
    outboxes (byte k of the stream to lane k mod len(outs)); the board takes them back in the
    same turn. A datagram is dropped whole (and counted) while more than cap bytes wait."""

    def __init__(self, outs, cap):
        self.outs, self.cap = outs, cap
        self.k = 0
        self.dropped = 0

    @property
    def buf(self):
        return any(o.buf for o in self.outs)

    def put(self, data):
        if sum(len(o.buf) for o in self.outs) > self.cap:
            self.dropped += 1
            return
        n = len(self.outs)
        for j, o in enumerate(self.outs):
            o.buf += data[(j - self.k) % n::n]
        self.k += len(data)
        self.flush()

    def flush(self):
        for o in self.outs:
            o.flush()


def lossy(data, p, rng):
    """data with each byte dropped with probability p."""
    if p <= 0.0:
        return data
    return bytes(b for b in data if rng.random() >= p)


class Stop(Exception):
    pass


def _stop(signum, frame):
    raise Stop()


def main(argv=None):
    a = parse(sys.argv[1:] if argv is None else argv)
    xp_addr = hostport("--xplane", a.xplane)
    gcs = hostport("--gcs", a.gcs)
    if not os.path.exists(a.elf):
        fail(f"no board image {a.elf}: run `make pil-images`")
    xp_sock = udp_bind(a.xp_listen, "X-Plane")
    mav_sock = udp_bind(a.mavlink_listen, "MAVLink")
    log = LogWriter(a.lcm, a.gen_python)

    tmp = tempfile.mkdtemp(prefix="octo-pil-")
    # UART0..UART4: the log's UART2 and the otherwise unused UART3 and UART4 carry plant lanes
    names = ("plant", "ground", "log", "lane3", "lane4")
    lane_names = ("plant", "log", "lane3", "lane4")
    try:
        drop_p = float(os.environ.get("OCTO_PIL_DROP", "0") or 0)
    except ValueError:
        drop_p = -1.0
    if not 0.0 <= drop_p < 1.0:
        fail(f"OCTO_PIL_DROP: a probability in [0, 1), not {os.environ.get('OCTO_PIL_DROP')}", 2)
    rng = random.Random(1)
    listeners = {}
    qemu = [a.qemu, "-M", "mps2-an386", "-display", "none", "-monitor", "none",
            "-semihosting-config", "enable=on,target=native", "-kernel", a.elf]
    if a.icount != "off":
        if not a.icount.isdigit() or int(a.icount) > 10:
            fail(f"--icount: a shift 0..10 or off, not {a.icount}", 2)
        qemu += ["-icount", f"shift={a.icount}"]
    qemu += os.environ.get("OCTO_PIL_QEMU_ARGS", "").split()   # further QEMU options, for experiments
    for n in names:
        path = os.path.join(tmp, n + ".sock")
        ls = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        ls.bind(path)
        ls.listen(1)
        listeners[n] = ls
        qemu += ["-chardev", f"socket,id={n},path={path}", "-serial", f"chardev:{n}"]
    counts = os.environ.get("OCTO_PIL_COUNTS")
    if counts:
        if not a.plugin or not os.path.exists(a.plugin):
            fail(f"OCTO_PIL_COUNTS: the counting plugin {a.plugin} is missing (make {a.plugin})")
        qemu += ["-plugin", f"{a.plugin},begin={symbol(a.elf, 'board_step_begin')},"
                 f"end={symbol(a.elf, 'board_step_end')},out={os.path.abspath(counts)}"]

    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, _stop)
    proc = None
    conns = {}
    rc = 0
    stats = {"plant_in": 0, "plant_bytes": 0, "foreign": 0, "plant_out": 0, "mav_in": 0, "mav_out": 0}
    t_first = t_last = None   # the first and the last X-Plane datagram: the flight's wall time
    plant_rx, log_rx, ground = SlipReader(), SlipReader(), MavSplitter()
    outs = {}
    try:
        proc = subprocess.Popen(qemu, stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + 10.0
        for n in names:
            listeners[n].settimeout(max(0.1, deadline - time.monotonic()))
            try:
                conns[n], _ = listeners[n].accept()
            except socket.timeout:
                fail(f"QEMU did not connect its {n} UART (status {proc.poll()})")
            conns[n].setblocking(False)
        say(f"board {os.path.basename(a.elf)} on QEMU mps2-an386 (pid {proc.pid}); X-Plane at "
            f"{xp_addr[0]}:{xp_addr[1]} (listening on {a.xp_listen}, actuation data25), MAVLink on "
            f"{a.mavlink_listen} -> {gcs[0]}:{gcs[1]}" + (f"; counting steps into {counts}" if counts else "")
            + (f"; dropping bytes towards the board with probability {drop_p:g}" if drop_p else ""))
        outs = {"plant": Lanes([Outbox(conns[n], 0) for n in lane_names], 65536),
                "ground": Outbox(conns["ground"], 65536)}
        sel = selectors.DefaultSelector()
        sel.register(xp_sock, selectors.EVENT_READ, "xp")
        sel.register(mav_sock, selectors.EVENT_READ, "mav")
        for n in names:
            sel.register(conns[n], selectors.EVENT_READ, n)
        while True:
            waiting = any(o.buf for o in outs.values())
            for key, _ in sel.select(timeout=0.002 if waiting else 0.2):
                what = key.data
                if what == "xp":
                    while True:
                        try:
                            data, src = xp_sock.recvfrom(65536)
                        except BlockingIOError:
                            break
                        if src[0] != xp_addr[0]:
                            stats["foreign"] += 1   # the board takes X-Plane's datagrams only
                            continue
                        stats["plant_in"] += 1
                        t_last = time.monotonic()
                        t_first = t_first or t_last
                        frame = slip_frame(data)
                        stats["plant_bytes"] += len(frame)
                        outs["plant"].put(lossy(frame, drop_p, rng))
                elif what == "mav":
                    while True:
                        try:
                            data, src = mav_sock.recvfrom(65536)
                        except BlockingIOError:
                            break
                        if data[:1] in (b"\xfd", b"\xfe"):
                            gcs = src
                        stats["mav_in"] += 1
                        outs["ground"].put(lossy(data, drop_p, rng))
                else:
                    try:
                        data = conns[what].recv(65536)
                    except BlockingIOError:
                        continue
                    if not data:
                        raise Stop()   # QEMU went away
                    if what in ("lane3", "lane4"):
                        continue   # receive-only lanes: the board sends nothing on them
                    if what == "plant":
                        for d in plant_rx.feed(data):
                            stats["plant_out"] += 1
                            xp_sock.sendto(d, xp_addr)
                    elif what == "ground":
                        for pkt in ground.feed(data):
                            stats["mav_out"] += 1
                            try:
                                mav_sock.sendto(pkt, gcs)
                            except OSError:
                                pass   # UDP: an absent ground station must not stop the board
                    else:
                        for rec in log_rx.feed(data):
                            log.record(rec)
            for o in outs.values():
                o.flush()
            if proc.poll() is not None:
                raise Stop()
    except Stop:
        pass
    except OSError as e:
        say(f"link to QEMU failed: {e}")
        rc = 1
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        if proc is not None:
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
            elif proc.returncode:
                rc = proc.returncode
                say(f"QEMU stopped with status {rc}" + (" (a fault on the board)" if rc == 126 else ""))
        log.close()
        for s in list(conns.values()) + list(listeners.values()):
            s.close()
        shutil.rmtree(tmp, ignore_errors=True)
    busy = sum(o.dropped for o in outs.values()) if conns else 0
    span = (t_last - t_first) if t_first else 0.0
    rate = f"{(stats['plant_in'] - 1) / span:.1f}" if span > 0 else "-"
    say(f"exit: {stats['plant_in']} X-Plane datagrams to the board in {span:.1f} s ({rate} a second, "
        f"{stats['plant_bytes'] / max(1, stats['plant_in']):.0f} bytes each on the UART; "
        f"{stats['foreign']} foreign dropped, "
        f"{busy} datagrams dropped while the board was busy), "
        f"{stats['plant_out']} from it, {plant_rx.dropped} frames dropped; log {log_rx.frames} records, "
        f"{log_rx.dropped} dropped; MAVLink {stats['mav_in']} datagrams in, {stats['mav_out']} packets out, "
        f"{ground.junk} bytes outside packets")
    return rc


if __name__ == "__main__":
    sys.exit(main())
