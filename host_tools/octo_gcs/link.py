"""The ground station's MAVLink link to one vehicle (pymavlink, MAVLink 2, dialect octo).

Everything here goes over MAVLink as any ground station would: heartbeat, the
parameter protocol (with the retries and checks QGroundControl and MAVProxy make),
COMMAND_LONG with acknowledgement, STATUSTEXT and NAMED_VALUE_FLOAT collection.
"""

import os
import time

# The project's dialect (firmware/mavlink/octo.xml: common.xml plus standard modes and
# component metadata), installed into pymavlink by `make`; MAVLINK_DIALECT overrides
# it as it does for pymavlink's own tools. Importing pymavlink sets MAVLINK_DIALECT=all
# when it is unset: that default, left by an earlier import in this process or inherited
# from a parent that imported pymavlink, is not a choice ("all" lacks the project's
# messages, OCTO_ID_RESULT among them).
_env_dialect = os.environ.get("MAVLINK_DIALECT")
if _env_dialect == "all":
    _env_dialect = None
DIALECT = _env_dialect or "octo"
os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402  (MAVLINK20 must be set first)

mavutil.set_dialect(DIALECT)
mavlink = mavutil.mavlink

from .base import (  # noqa: E402,F401
    DEFAULT_URL,
    FW_PARAMS,
    MODE_NUMBERS,
    MODES,
    GcsError,
    f32,  # (re-exported)
    fw_default,
)


def read_signing_key(path):
    """32-byte key from FILE: its text with surrounding white space stripped is either
    exactly 64 hex digits (the key) or a passphrase (key = its sha256, MAVProxy's rule).
    octo-fw --signing-key applies the same rule, so one file serves both."""
    import hashlib
    import string

    raw = open(path, "rb").read().strip()
    # all 64 characters hex digits: bytes.fromhex alone would also take "ab cd ..."
    # (spaces inside) and give a key shorter than 32 bytes
    if len(raw) == 64 and all(chr(c) in string.hexdigits for c in raw):
        return bytes.fromhex(raw.decode("ascii"))
    if not raw:
        raise GcsError(f"signing key file {path} is empty")
    return hashlib.sha256(raw).digest()


def result_name(result):
    """'ACCEPTED', 'DENIED', ... for a MAV_RESULT value."""
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name.replace("MAV_RESULT_", "") if entry is not None else f"result {result}"


STATUSTEXT_LEN = 50  # STATUSTEXT.text: a full chunk has no NUL, so more follow


class Vehicle:
    """A connection to one vehicle. Use as a context manager to close the socket."""

    def __init__(self, url=DEFAULT_URL, timeout=5.0, signing_key=None, source_system=255):
        self.url = url
        self.timeout = timeout
        try:
            self.conn = mavutil.mavlink_connection(
                url,
                source_system=source_system,
                source_component=mavlink.MAV_COMP_ID_MISSIONPLANNER,
                autoreconnect=True,
            )
        except Exception as e:  # pymavlink raises bare exceptions for bad URLs
            raise GcsError(f"cannot open {url}: {e}") from None
        if signing_key is not None:
            self.conn.setup_signing(read_signing_key(signing_key), sign_outgoing=True)
        self.target_system = 1
        self.target_component = 1
        self.statustexts = []  # (wall time, severity, text), long lines joined
        self._chunks = {}  # (system, component) -> (id, next chunk_seq, text so far)
        self.named_values = {}  # name -> (time_boot_ms, value)
        self.heartbeat = None
        self.mode = None  # octo-fw's mode (HEARTBEAT.custom_mode / "Mode X" texts)
        self.listeners = []  # callables(msg) that see every message received

    # ------------------------------------------------------------ plumbing
    def close(self):
        self.conn.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _join_chunks(self, msg):
        """A STATUSTEXT's whole line, or None while a long one's chunks are still coming.

        id 0 is a line by itself; a nonzero id marks chunks of one long line (chunk_seq from
        0), ended by the chunk shorter than the 50-character field. A lost chunk is marked
        "[...]" rather than dropped silently; a line whose last chunk never comes is lost with it.
        """
        cid = getattr(msg, "id", 0)
        if not cid:
            return msg.text
        key = (msg.get_srcSystem(), msg.get_srcComponent())
        have = self._chunks.get(key)
        if have is None or have[0] != cid:  # a new line: its start lost if this is not chunk 0
            have = (cid, 0, "")
        text = have[2] + ("[...]" if msg.chunk_seq > have[1] else "") + msg.text
        if len(msg.text) < STATUSTEXT_LEN:
            self._chunks.pop(key, None)
            return text
        self._chunks[key] = (cid, msg.chunk_seq + 1, text)
        return None

    def _note(self, msg):
        t = msg.get_type()
        if t == "STATUSTEXT":
            text = self._join_chunks(msg)
            if text is None:
                return
            self.statustexts.append((time.time(), msg.severity, text))
            if text.startswith("Mode ") and text[5:] in MODE_NUMBERS:
                self.mode = MODE_NUMBERS[text[5:]]
        elif t == "NAMED_VALUE_FLOAT":
            self.named_values[msg.name] = (msg.time_boot_ms, msg.value)
        elif (
            t == "HEARTBEAT"
            and msg.get_srcComponent() == self.target_component
            and msg.type != mavlink.MAV_TYPE_GCS
        ):
            self.heartbeat = msg
            self.mode = msg.custom_mode
        for f in self.listeners:
            f(msg)

    def recv(self, types=None, timeout=1.0, cond=None):
        """Next message of one of `types` (and satisfying cond) within `timeout` s, else None.
        Every message passing by is noted (status texts, named values, heartbeats)."""
        deadline = time.monotonic() + timeout
        if isinstance(types, str):
            types = (types,)
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            msg = self.conn.recv_match(blocking=True, timeout=min(left, 0.1))
            if msg is None:
                continue
            if msg.get_type() == "BAD_DATA":
                continue
            self._note(msg)
            if types is not None and msg.get_type() not in types:
                continue
            if cond is not None and not cond(msg):
                continue
            return msg

    def wait_heartbeat(self, timeout=None):
        timeout = self.timeout if timeout is None else timeout
        msg = self.recv("HEARTBEAT", timeout, cond=lambda m: m.type != mavlink.MAV_TYPE_GCS)
        if msg is None:
            raise GcsError(f"no heartbeat from a vehicle on {self.url} after {timeout:g} s")
        self.target_system = msg.get_srcSystem()
        self.target_component = msg.get_srcComponent()
        self.heartbeat = msg
        self.mode = msg.custom_mode
        return msg

    # ------------------------------------------------------------ parameters
    def fetch_params(self, timeout=None):
        """All parameters as {name: value}: PARAM_REQUEST_LIST, then missing indices
        re-read one by one (as MAVProxy does). Raises GcsError if some stay missing."""
        timeout = self.timeout if timeout is None else timeout
        self.conn.mav.param_request_list_send(self.target_system, self.target_component)
        values, count = {}, None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            m = self.recv("PARAM_VALUE", 0.5)
            if m is None:
                if count is not None:
                    break
                continue
            count = m.param_count
            values[m.param_index] = (m.param_id, m.param_value)
            if len(values) >= count:
                break
        if count is None:
            raise GcsError(f"no PARAM_VALUE from the vehicle on {self.url} after {timeout:g} s")
        for _ in range(3):
            missing = [i for i in range(count) if i not in values]
            if not missing:
                break
            for i in missing:
                self.conn.mav.param_request_read_send(self.target_system, self.target_component, b"", i)
                m = self.recv("PARAM_VALUE", 1.0, cond=lambda m, i=i: m.param_index == i)
                if m is not None:
                    values[i] = (m.param_id, m.param_value)
        missing = [i for i in range(count) if i not in values]
        if missing:
            raise GcsError(f"parameters with index {missing} never arrived")
        return {name: value for _, (name, value) in sorted(values.items())}

    def get_param(self, name, retries=3):
        for _ in range(retries):
            self.conn.mav.param_request_read_send(
                self.target_system, self.target_component, name.encode(), -1
            )
            m = self.recv("PARAM_VALUE", 1.0, cond=lambda m: m.param_id == name)
            if m is not None:
                return m.param_value
        why = self._last_text()
        raise GcsError(
            f"no parameter {name} on the vehicle"
            + (
                f" ({why})"
                if why
                else " (no answer: unknown name, or the vehicle wants signed messages: --signing-key)"
            )
        )

    def set_param(self, name, value, retries=3):
        """PARAM_SET with the echo check ground stations make. Returns the echoed value;
        raises GcsError with the vehicle's reason if the write is refused."""
        want = f32(value)
        echoed = None
        for _ in range(retries):
            t0 = time.time()
            self.conn.mav.param_set_send(
                self.target_system, self.target_component, name.encode(), want, mavlink.MAV_PARAM_TYPE_REAL32
            )
            m = self.recv("PARAM_VALUE", 1.0, cond=lambda m: m.param_id == name)
            if m is None:
                continue
            echoed = m.param_value
            if echoed == want:
                return echoed
            # a refusal: the vehicle echoed its current value; wait briefly for the reason
            self.recv("STATUSTEXT", 0.2, cond=lambda s: True)
            reason = self._last_text(since=t0)
            raise GcsError(
                f"vehicle refused {name} = {value:g}: kept {echoed:g}" + (f" ({reason})" if reason else "")
            )
        if echoed is None:
            raise GcsError(f"no answer to setting {name} ({self._last_text() or 'unknown name?'})")
        raise GcsError(f"{name}: vehicle answered {echoed:g}, not {want:g}")

    def _last_text(self, since=0.0):
        texts = [t for (w, _, t) in self.statustexts if w >= since]
        return texts[-1] if texts else ""

    # ------------------------------------------------------------ commands
    def command(self, cmd, *params, timeout=None, retries=3, progress=None):
        """COMMAND_LONG, retried with confirmation+1; waits through IN_PROGRESS acks.
        Returns the final MAV_RESULT value. progress(percent) is called on IN_PROGRESS."""
        timeout = self.timeout if timeout is None else timeout
        p = list(params) + [0.0] * (7 - len(params))
        for confirmation in range(retries):
            self.conn.mav.command_long_send(self.target_system, self.target_component, cmd, confirmation, *p)
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                ack = self.recv("COMMAND_ACK", deadline - time.monotonic(), cond=lambda a: a.command == cmd)
                if ack is None:
                    break
                if ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
                    if progress is not None:
                        progress(ack.progress)
                    deadline = time.monotonic() + timeout
                    continue
                return ack.result
        raise GcsError(f"no COMMAND_ACK for command {cmd} after {retries} tries")
