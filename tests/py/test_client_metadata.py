"""Parameter metadata the way QGroundControl and MAVSDK read it: COMPONENT_METADATA
(and COMPONENT_INFORMATION for older readers) point to a general metadata file on
the vehicle's read-only MAVLink FTP, which points to the parameter metadata (units,
ranges, defaults, descriptions from the parameter table), generated at build time
and served xz-compressed (both clients decompress a `.xz` file). MAVSDK's own
component metadata client downloads and decodes it; every other FTP request is
NAKed. Every wait has a deadline."""

import json
import lzma
import struct
import subprocess
import time
import zlib

import pytest

from conftest import binary
from octo_gcs import link  # noqa: F401  (loads the octo dialect into pymavlink)
from test_fw_rig import Rig

mavsdk = pytest.importorskip("mavsdk")
from mavsdk.plugins.component_metadata import ComponentMetadata, MetadataType  # noqa: E402

M = link.mavlink
OP_OPEN_RO, OP_READ, OP_BURST, OP_LIST, OP_WRITE, OP_CRC, OP_TERM = 4, 5, 15, 3, 7, 14, 1
ACK, NAK = 128, 129


def table():
    r = subprocess.run([str(binary("octo-fw")), "--dump-params"], capture_output=True, text=True, timeout=10)
    return json.loads(r.stdout)["params"]


def check_param_metadata(doc):
    assert doc["version"] == 1
    by_name = {p["name"]: p for p in doc["parameters"]}
    t = table()
    assert set(by_name) == {p["name"] for p in t}
    for p in t:
        q = by_name[p["name"]]
        assert q["type"] == "Float"
        assert q["units"] == p["unit"] and q["shortDesc"] == p["description"]
        assert (q["default"], q["min"], q["max"]) == (p["default"], p["min"], p["max"])
        assert q["group"] == p["name"].split("_")[0]


def varint(b, i):
    """xz's multibyte integer at b[i]: (value, next index)"""
    v, k = 0, 0
    while True:
        v |= (b[i] & 0x7F) << (7 * k)
        i, k = i + 1, k + 1
        if not b[i - 1] & 0x80:
            return v, i


def check_xz(data):
    """What xz-embedded (QGroundControl) decodes as well as liblzma (MAVSDK): one xz
    stream with the CRC32 check and one block of LZMA2 alone; returns the JSON text."""
    assert data[:6] == b"\xfd7zXZ\x00" and data[-2:] == b"YZ"
    assert data[6:8] == b"\x00\x01"                        # stream flags: check = CRC32
    flags = data[13]                                      # the first block header's flags
    assert flags & 0x03 == 0                              # one filter
    i = 14
    for bit in (0x40, 0x80):                              # compressed, uncompressed size
        if flags & bit:
            i = varint(data, i)[1]
    assert varint(data, i)[0] == 0x21                     # LZMA2
    text = lzma.decompress(data, format=lzma.FORMAT_XZ)   # verifies the CRC32 too
    assert lzma.LZMADecompressor(format=lzma.FORMAT_XZ).decompress(data) == text
    return text


def test_mavsdk_downloads_the_parameter_metadata(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    rig.start_sim(lockstep=False)
    rig.start_fw()
    m = mavsdk.Mavsdk(mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.GROUND_STATION))
    try:
        assert m.add_any_connection(f"udpin://127.0.0.1:{rig.gcs_port}") == mavsdk.ConnectionResult.SUCCESS
        system = m.first_autopilot(10.0)
        assert system is not None, "MAVSDK found no autopilot within 10 s"
        cm = ComponentMetadata(system)
        cm.request_autopilot_component()
        deadline, doc, err = time.monotonic() + 20.0, None, None
        while doc is None and time.monotonic() < deadline:
            try:
                doc = json.loads(cm.get_metadata(1, MetadataType.PARAMETER).json_metadata)
            except Exception as e:   # not there yet (MAVSDK raises until the download ends)
                err = e
                time.sleep(0.2)
        assert doc is not None, f"MAVSDK got no parameter metadata within 20 s: {err}"
        check_param_metadata(doc)
    finally:
        m.destroy()


class Ftp:
    def __init__(self, rig):
        self.rig, self.seq = rig, 0

    def request(self, opcode, session=0, offset=0, size=0, data=b""):
        self.seq += 1
        p = struct.pack("<HBBBBBxI", self.seq, session, opcode, size or len(data), 0, 0, offset) + data
        self.rig.m.mav.file_transfer_protocol_send(0, 1, 1, list(p.ljust(251, b"\0")))
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline:
            msg = self.rig.recv({"FILE_TRANSFER_PROTOCOL"}, timeout=deadline - time.monotonic())
            if msg is None:
                break
            b = bytes(msg.payload)
            seq, sess, op, sz, req_op, burst, off = struct.unpack("<HBBBBBxI", b[:12])
            if seq == (self.seq + 1) & 0xFFFF and req_op == opcode:
                return op, sz, off, b[12:12 + sz], burst
        pytest.fail(f"no FTP answer to opcode {opcode} within 3 s")

    def read(self, path):
        op, sz, _, d, _ = self.request(OP_OPEN_RO, data=path.encode())
        assert op == ACK and sz == 4, (op, d)
        length, out = struct.unpack("<I", d)[0], b""
        while len(out) < length:
            op, sz, off, d, _ = self.request(OP_READ, offset=len(out), size=239)
            assert op == ACK and off == len(out) and sz > 0
            out += d
        op, _, _, d, _ = self.request(OP_READ, offset=len(out), size=239)
        assert (op, d[0]) == (NAK, 6)                    # EOF
        assert self.request(OP_TERM)[0] == ACK
        return out


def test_component_messages_and_read_only_ftp(launch, port, tmp_path):
    rig = Rig(launch, port, tmp_path)
    rig.start_fw()
    rig.connect()
    def requested(msgid, name):
        rig.m.mav.command_long_send(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, msgid, 0, 0, 0, 0, 0, 0)
        return rig.recv({name}, timeout=3)

    meta = requested(M.MAVLINK_MSG_ID_COMPONENT_METADATA, "COMPONENT_METADATA")
    assert meta is not None and meta.uri.startswith("mftp://")
    info = requested(M.MAVLINK_MSG_ID_COMPONENT_INFORMATION, "COMPONENT_INFORMATION")
    assert info is not None and info.general_metadata_uri == meta.uri
    assert info.general_metadata_file_crc == meta.file_crc

    ftp = Ftp(rig)
    path = meta.uri[len("mftp://"):]
    general = ftp.read(path)
    assert zlib.crc32(general) == meta.file_crc
    g = json.loads(general)
    (ptype,) = g["metadataTypes"]
    assert ptype["type"] == 1 and ptype["uri"].startswith("mftp://")   # COMP_METADATA_TYPE_PARAMETER
    assert ptype["uri"].endswith(".json.xz")    # the clients choose the decoder by the name
    params = ftp.read(ptype["uri"][len("mftp://"):])
    assert zlib.crc32(params) == ptype["fileCrc"]
    text = check_xz(params)
    check_param_metadata(json.loads(text))
    # the very JSON the parameter table gives on the host (the generator's input)
    r = subprocess.run([str(binary("tools/param-meta"))], capture_output=True, timeout=10, check=True)
    assert text == r.stdout
    # the CRC the vehicle computes is the same
    op, _, _, d, _ = ftp.request(OP_CRC, data=path.encode())
    assert op == ACK and struct.unpack("<I", d)[0] == meta.file_crc
    # a burst read brings the whole file, the last packet flagged
    assert ftp.request(OP_OPEN_RO, data=path.encode())[0] == ACK
    op, sz, off, d, burst = ftp.request(OP_BURST)
    got = {off: d}
    deadline = time.monotonic() + 3.0
    while not burst and time.monotonic() < deadline:
        msg = rig.recv({"FILE_TRANSFER_PROTOCOL"}, timeout=0.5)
        if msg is not None:
            b = bytes(msg.payload)
            _, _, op, sz, req_op, burst, off = struct.unpack("<HBBBBBxI", b[:12])
            if req_op == OP_BURST and op == ACK:
                got[off] = b[12:12 + sz]
    assert burst, "the burst never ended"
    assert b"".join(got[k] for k in sorted(got)) == general
    assert ftp.request(OP_TERM)[0] == ACK

    # everything else is still NAKed: other files, listing, writing
    for opcode, data, err in ((OP_OPEN_RO, b"@PARAM/param.pck", 10), (OP_OPEN_RO, b"octo/param.json", 10),
                              (OP_LIST, b"/", 10),
                              (OP_WRITE, b"x", 10), (99, b"", 7)):
        op, _, _, d, _ = ftp.request(opcode, data=data)
        assert (op, d[0]) == (NAK, err), (opcode, op, d)
    # reading without an open session
    op, _, _, d, _ = ftp.request(OP_READ, size=10)
    assert (op, d[0]) == (NAK, 4)


def test_signed_link_signs_metadata_ftp_and_telemetry(launch, port, tmp_path):
    """With signing on, what the endpoint's helper files pack (component metadata, FTP
    replies, the telemetry of mav_telem.c) is signed like the rest, on one sequence."""
    from pymavlink import mavutil
    from octo_gcs.link import read_signing_key
    key = tmp_path / "pass.txt"
    key.write_text("metadata signing passphrase\n")
    rig = Rig(launch, port, tmp_path)
    rig.start_fw("--signing-key", key)
    rig.m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{rig.gcs_port}", source_system=255,
                                       source_component=190)
    got = []
    # unsigned messages are let through here so that they can be counted
    rig.m.setup_signing(read_signing_key(key), sign_outgoing=True,
                        allow_unsigned_callback=lambda mav, msgid: True)
    rig.m.message_hooks.append(lambda conn, msg: got.append(msg))   # everything received
    rig.connect()
    rig.m.mav.command_long_send(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, M.MAVLINK_MSG_ID_COMPONENT_METADATA,
                                0, 0, 0, 0, 0, 0)
    meta = rig.recv({"COMPONENT_METADATA"}, timeout=3)
    assert meta is not None
    general = Ftp(rig).read(meta.uri[len("mftp://"):])
    assert zlib.crc32(general) == meta.file_crc
    deadline = time.monotonic() + 2.0
    while time.monotonic() < deadline:
        rig.m.recv_match(blocking=True, timeout=0.2)
    types = {m.get_type() for m in got}
    assert {"HEARTBEAT", "COMPONENT_METADATA", "FILE_TRANSFER_PROTOCOL", "EXTENDED_SYS_STATE"} <= types, types
    unsigned = sorted({m.get_type() for m in got if not m._signed})
    assert not unsigned, f"sent unsigned: {unsigned}"
