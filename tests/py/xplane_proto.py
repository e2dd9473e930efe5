"""X-Plane 11/12 native UDP protocol, written from docs/xplane-protocol.md only.

A small, dependency-free codec for tests and tools (independent of octo-sim's
C++ encoder, so that neither side can hide the other's mistake):

    encode_data({25: [0.5] * 8})           DATA to X-Plane (byte 4 = 0x00)
    decode_data(datagram)                  DATA output -> {row: (c1..c8)}
    encode_dref(path, value)               DREF, 509 bytes
    encode_rref(freq, index, path)         RREF request, 413 bytes
    decode_rref(datagram)                  RREF reply -> [(index, value), ...]
    encode_dsel(rows) / encode_usel(rows)  DSEL / USEL
    encode_cmnd(path), encode_ise4(ip, port, enable)

and `Link`, a UDP socket that talks to an X-Plane (or octo-sim) on localhost.
Every decoder raises ProtocolError on a malformed datagram.
"""

import math
import socket
import struct
import time

NO_DATA = -999.0                       # "leave alone" in, "nothing here" out
NO_DATA_BYTES = b"\x00\xc0\x79\xc4"
DATA_OUT_BYTE4 = 0x2A                  # '*' on X-Plane 11 and 12
RREF_OUT_BYTE4 = 0x2C                  # ',' on X-Plane 11 and 12
DREF_SIZE = 509
RREF_REQUEST_SIZE = 413
ISE4_SIZE = 37
RREF_MAX_RECORDS = 183

# units
N_PER_LB = 4.4482216152605
NM_PER_FTLB = 1.3558179483314
M_PER_FT = 0.3048

# engines are 0-based in datarefs, 1-based in DATA columns
THRO_USE = "sim/flightmodel/engine/ENGN_thro_use"
OVERRIDE_THROTTLES = "sim/operation/override/override_throttles"
VERSION_DATAREF = "sim/version/xplane_internal_version"


class ProtocolError(ValueError):
    """A datagram that does not follow the X-Plane protocol."""


def _header(tag: bytes, byte4: int) -> bytes:
    assert len(tag) == 4
    return tag + bytes([byte4])


def message_type(dgram: bytes) -> str:
    """The 4-letter type of a datagram (byte 4 is ignored, as X-Plane does)."""
    if len(dgram) < 5:
        raise ProtocolError(f"datagram of {len(dgram)} bytes is shorter than the 5-byte header")
    return dgram[:4].decode("ascii", errors="replace")


# ----------------------------------------------------------------- DATA
def encode_data(rows, byte4: int = 0) -> bytes:
    """DATA datagram. rows: {row: columns} or [(row, columns)]; columns has at most
    8 values (missing ones are -999, None is -999)."""
    items = rows.items() if isinstance(rows, dict) else rows
    out = bytearray(_header(b"DATA", byte4))
    for row, cols in items:
        cols = [NO_DATA if c is None else float(c) for c in cols]
        if len(cols) > 8:
            raise ValueError("a DATA row has 8 columns")
        cols += [NO_DATA] * (8 - len(cols))
        out += struct.pack("<i8f", int(row), *cols)
    return bytes(out)


def decode_data_list(dgram: bytes):
    """DATA datagram -> [(row, (c1..c8)), ...] in datagram order."""
    if message_type(dgram) != "DATA":
        raise ProtocolError("not a DATA datagram")
    body = dgram[5:]
    if len(body) % 36:
        raise ProtocolError(f"DATA payload of {len(body)} bytes is not a multiple of 36")
    return [(r[0], tuple(r[1:])) for r in struct.iter_unpack("<i8f", body)]


def decode_data(dgram: bytes) -> dict:
    """DATA datagram -> {row: (c1..c8)}."""
    return dict(decode_data_list(dgram))


def is_no_data(v: float) -> bool:
    return v == NO_DATA


# ----------------------------------------------------------------- DREF
def encode_dref(path: str, value: float, byte4: int = 0, pad: bytes = b"\x00") -> bytes:
    """DREF: float32 value and the path NUL-terminated in a 500-byte field. `pad`
    fills the field after the NUL (b"\\x00" or b" ")."""
    p = path.encode("ascii")
    if len(p) >= 500:
        raise ValueError("dataref path too long")
    field = p + b"\x00"
    field += pad * (500 - len(field))
    return _header(b"DREF", byte4) + struct.pack("<f", value) + field


def decode_dref(dgram: bytes):
    """DREF -> (path, value)."""
    if message_type(dgram) != "DREF" or len(dgram) != DREF_SIZE:
        raise ProtocolError("not a 509-byte DREF")
    (value,) = struct.unpack_from("<f", dgram, 5)
    return _path(dgram[9:]), value


def _path(field: bytes) -> str:
    nul = field.find(b"\x00")
    if nul <= 0:
        raise ProtocolError("path not NUL-terminated in its field")
    return field[:nul].decode("ascii")


def throttle_drefs(throttles, byte4: int = 0):
    """One DREF per engine, ENGN_thro_use[i] = throttles[i]."""
    return [encode_dref(f"{THRO_USE}[{i}]", t, byte4) for i, t in enumerate(throttles)]


# ----------------------------------------------------------------- RREF
def encode_rref(freq: int, index: int, path: str, byte4: int = 0) -> bytes:
    """RREF request: freq per second (0 stops), client index, path in 400 bytes."""
    p = path.encode("ascii")
    if len(p) >= 400:
        raise ValueError("dataref path too long")
    return _header(b"RREF", byte4) + struct.pack("<ii", freq, index) + p.ljust(400, b"\x00")


def decode_rref_request(dgram: bytes):
    """RREF request -> (freq, index, path)."""
    if message_type(dgram) != "RREF" or len(dgram) != RREF_REQUEST_SIZE:
        raise ProtocolError("not a 413-byte RREF request")
    freq, index = struct.unpack_from("<ii", dgram, 5)
    return freq, index, _path(dgram[13:])


def encode_rref_reply(records, byte4: int = RREF_OUT_BYTE4):
    """RREF replies as X-Plane sends them: [(index, value)] -> list of datagrams,
    at most 183 records each."""
    records = list(records)
    out = []
    for i in range(0, max(len(records), 1), RREF_MAX_RECORDS):
        chunk = records[i:i + RREF_MAX_RECORDS]
        out.append(_header(b"RREF", byte4) + b"".join(struct.pack("<if", k, v) for k, v in chunk))
    return out


def decode_rref(dgram: bytes):
    """RREF reply -> [(index, value), ...]."""
    if message_type(dgram) != "RREF":
        raise ProtocolError("not an RREF reply")
    body = dgram[5:]
    if len(body) % 8:
        raise ProtocolError(f"RREF reply payload of {len(body)} bytes is not a multiple of 8")
    if len(body) // 8 > RREF_MAX_RECORDS:
        raise ProtocolError("more than 183 records in one RREF reply")
    return [tuple(r) for r in struct.iter_unpack("<if", body)]


# ----------------------------------------------------------------- DSEL / USEL / CMND / ISE4
def encode_dsel(rows, byte4: int = 0) -> bytes:
    return _header(b"DSEL", byte4) + b"".join(struct.pack("<i", r) for r in rows)


def encode_usel(rows, byte4: int = 0) -> bytes:
    return _header(b"USEL", byte4) + b"".join(struct.pack("<i", r) for r in rows)


def encode_cmnd(path: str, byte4: int = 0) -> bytes:
    return _header(b"CMND", byte4) + path.encode("ascii") + b"\x00"


def encode_ise4(ip: str, port: int, enable: int = 1, index: int = 64) -> bytes:
    """ISE4 ('<4sxi16s8si'): index 64 sets the Data Output target."""
    return struct.pack("<4sxi16s8si", b"ISE4", index, ip.encode("ascii"), str(port).encode("ascii"), enable)


# ----------------------------------------------------------------- frames
def ned_from_opengl(x, y, z):
    """OpenGL local (east, up, south) -> (north, east, down)."""
    return -z, x, -y


def row16_pqr(cols, version: int):
    """Row 16 -> (P, Q, R) in rad/s for X-Plane 11 (Q, P, R rad/s) or 12 (P, Q, R deg/s)."""
    if version >= 12:
        return tuple(math.radians(c) for c in cols[:3])
    return cols[1], cols[0], cols[2]


# ----------------------------------------------------------------- a UDP link
class Link:
    """A UDP socket on 127.0.0.1 (its port is where Data Output should go) that
    sends requests to an X-Plane at `xp_addr`."""

    def __init__(self, xp_port: int, port: int = 0, host: str = "127.0.0.1"):
        self.xp = (host, xp_port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        self.sock.bind((host, port))
        self.port = self.sock.getsockname()[1]

    def close(self):
        self.sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def send(self, dgram: bytes):
        self.sock.sendto(dgram, self.xp)

    def recv(self, timeout: float = 2.0):
        """Next datagram (bytes) or None after `timeout` seconds."""
        self.sock.settimeout(timeout)
        try:
            return self.sock.recvfrom(65536)[0]
        except (socket.timeout, BlockingIOError):
            return None

    def recv_type(self, kind: str, timeout: float = 2.0):
        """Next datagram of a type ('DATA', 'RREF'), skipping others, or None."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            d = self.recv(left)
            if d is None:
                return None
            if len(d) >= 5 and d[:4] == kind.encode():
                return d

    def recv_data(self, timeout: float = 2.0):
        """Next DATA output as {row: cols}, or None."""
        d = self.recv_type("DATA", timeout)
        return None if d is None else decode_data(d)

    def drain(self, quiet: float = 0.0):
        """Discard what is queued (waiting up to `quiet` s for stragglers)."""
        out = []
        while True:
            d = self.recv(quiet) if quiet > 0 else self._poll()
            if d is None:
                return out
            out.append(d)

    def _poll(self):
        self.sock.setblocking(False)
        try:
            return self.sock.recvfrom(65536)[0]
        except (BlockingIOError, socket.timeout):
            return None
        finally:
            self.sock.setblocking(True)
