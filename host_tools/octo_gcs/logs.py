"""Reading the LCM logs of octo-sim (OCTO_TRUTH) and octo-fw (OCTO_FW_FRAME, OCTO_FW_EVENT,
OCTO_FW_ID_RESULT).

Both programs write LCM event logs stamped with plant (simulated) time when given
``--lcm file://PATH``. A log is recognised by its channels, not by its name.
Records become a `Series`: one numpy array per field (arrays of shape (n, k) for
array fields), so ``fw.throttle[:, 0]`` is T_1 over time.
"""

import os
import struct

import numpy as np

from . import id_results
from .base import GcsError
from .experiments import phase_of

SYNC = 0xEDA1DA01
_HDR = struct.Struct(">IqqII")

CHANNELS = ("OCTO_TRUTH", "OCTO_FW_FRAME", "OCTO_FW_EVENT", "OCTO_FW_ID_RESULT")


def _types():
    try:
        from octo import fw_event_t, fw_frame_t, fw_id_result_t, truth_t
    except ImportError:
        raise GcsError("the LCM Python types (package 'octo') are missing: run `make`") from None
    return {
        "OCTO_TRUTH": truth_t,
        "OCTO_FW_FRAME": fw_frame_t,
        "OCTO_FW_EVENT": fw_event_t,
        "OCTO_FW_ID_RESULT": fw_id_result_t,
    }


def read_events(path):
    """[(channel, utime, data bytes)] of an LCM event log (a torn last event is ignored)."""
    out = []
    try:
        f = open(path, "rb")
    except OSError as e:
        raise GcsError(f"cannot read log {path}: {e.strerror}") from None
    with f:
        buf = f.read()
    off, n = 0, len(buf)
    unpack, hsize, names = _HDR.unpack_from, _HDR.size, {}  # names: channel bytes -> str, decoded once
    append = out.append
    while off + hsize <= n:
        sync, _num, utime, clen, dlen = unpack(buf, off)
        if sync != SYNC:
            raise GcsError(f"{path}: not an LCM event log (bad sync word at byte {off})")
        start = off + hsize
        mid = start + clen
        end = mid + dlen
        if end > n:
            break
        raw = buf[start:mid]
        channel = names.get(raw)
        if channel is None:
            channel = names[raw] = raw.decode("ascii", errors="replace")
        append((channel, utime, buf[mid:end]))
        off = end
    return out


# numpy's big-endian types of LCM's fixed-size primitives, and the native types the
# fields become (those of decoding message by message: Python ints, floats and bools)
_NP = {
    "int8_t": ("i1", np.int64),
    "int16_t": (">i2", np.int64),
    "int32_t": (">i4", np.int64),
    "int64_t": (">i8", np.int64),
    "byte": ("u1", np.int64),
    "boolean": ("i1", np.bool_),
    "float": (">f4", np.float64),
    "double": (">f8", np.float64),
}


def _fixed_dtype(lcm_type):
    """The numpy record type of an LCM type made of fixed-size primitive fields (with its
    8-byte fingerprint first), or None when it has strings, nested types or variable
    arrays (such a type is decoded message by message)."""
    names = getattr(lcm_type, "__slots__", None)
    types = getattr(lcm_type, "__typenames__", None)
    dims = getattr(lcm_type, "__dimensions__", None)
    if not names or types is None or dims is None:
        return None
    fields = [("_fingerprint", ">u8")]
    for name, t, d in zip(names, types, dims):
        if t not in _NP or (d is not None and not all(isinstance(k, int) for k in d)):
            return None
        fields.append((name, _NP[t][0], tuple(d)) if d else (name, _NP[t][0]))
    return np.dtype(fields)


def _decode_fixed(lcm_type, dtype, datas, path, channel):
    """{field: array} of many messages of one fixed-size type at once (numpy), checked
    as LCM's decode checks them (size and fingerprint)."""
    if any(len(d) != dtype.itemsize for d in datas):
        raise GcsError(
            f"{path}: {channel} record does not decode (wrong size): "
            "log from another version of the LCM types?"
        )
    rec = np.frombuffer(b"".join(datas), dtype=dtype)
    fp = int.from_bytes(lcm_type._get_packed_fingerprint(), "big")
    if len(rec) and np.any(rec["_fingerprint"] != fp):
        raise GcsError(
            f"{path}: {channel} record does not decode (Decode error): "
            "log from another version of the LCM types?"
        )
    natives = dict(zip(lcm_type.__slots__, (_NP[t][1] for t in lcm_type.__typenames__)))
    return {name: rec[name].astype(natives[name]) for name in lcm_type.__slots__}


class Series:
    """Fields of a list of LCM messages as numpy arrays (attribute access)."""

    @classmethod
    def from_arrays(cls, fields):
        s = cls([])
        s._fields = dict(fields)
        s.n = len(next(iter(fields.values()))) if fields else 0
        return s

    def __init__(self, msgs):
        self.n = len(msgs)
        self._fields = {}
        if msgs:
            for name in msgs[0].__slots__:
                vals = [getattr(m, name) for m in msgs]
                if isinstance(vals[0], (str, bytes)):
                    self._fields[name] = vals
                else:
                    self._fields[name] = np.asarray(vals)

    def __getattr__(self, name):
        try:
            return self.__dict__["_fields"][name]
        except KeyError:
            raise AttributeError(name) from None

    def has(self, name):
        return name in self._fields

    def __len__(self):
        return self.n

    def select(self, mask):
        s = Series([])
        s.n = int(np.count_nonzero(mask))
        s._fields = {
            k: (v[mask] if isinstance(v, np.ndarray) else [x for x, m in zip(v, mask) if m])
            for k, v in self._fields.items()
        }
        return s


class _Row:
    """Record i of a Series, by attribute."""

    def __init__(self, series, i):
        self._s, self._i = series, i

    def __getattr__(self, name):
        return getattr(self._s, name)[self._i]


class Logs:
    """The truth (octo-sim) and firmware (octo-fw) records found in some log files."""

    def __init__(self, paths):
        types = _types()
        raw = {c: {} for c in CHANNELS}  # channel -> {path: [data, ...]} in the files' order
        self.paths = [str(p) for p in paths]
        for p in paths:
            lists = {c: [] for c in CHANNELS}
            for channel, _utime, data in read_events(p):
                got = lists.get(channel)
                if got is not None:
                    got.append(data)
            for c, datas in lists.items():
                if datas:
                    raw[c].setdefault(p, []).extend(datas)
        if not any(raw.values()):
            raise GcsError("no OCTO_TRUTH or OCTO_FW_* records in " + ", ".join(self.paths))
        series = {}
        for channel, by_path in raw.items():
            if not by_path:
                series[channel] = None
                continue
            dtype = _fixed_dtype(types[channel])
            if dtype is not None and len(by_path) == 1:
                ((p, datas),) = by_path.items()
                series[channel] = Series.from_arrays(_decode_fixed(types[channel], dtype, datas, p, channel))
                continue
            msgs = []
            for p, datas in by_path.items():
                for data in datas:
                    try:
                        msgs.append(types[channel].decode(data))
                    except ValueError as e:
                        raise GcsError(
                            f"{p}: {channel} record does not decode ({e}): "
                            "log from another version of the LCM types?"
                        ) from None
            series[channel] = msgs
        self.truth = self._series(series["OCTO_TRUTH"])
        self.fw = self._series(series["OCTO_FW_FRAME"])
        self.events = [(e.utime * 1e-6, e.severity, e.text) for e in (series["OCTO_FW_EVENT"] or [])]
        self.id_results = self._records(series["OCTO_FW_ID_RESULT"])

    @staticmethod
    def _records(x):
        """The identification results (id_results.record dicts), in the log's order."""
        if x is None:
            return []
        if isinstance(x, Series):
            return [id_results.record(_Row(x, i)) for i in range(len(x))]
        return [id_results.record(r) for r in x]

    @staticmethod
    def _series(x):
        if x is None or isinstance(x, Series):
            return x
        return Series(x)

    # ------------------------------------------------------------ experiment phases
    def phases(self):
        """[(name, t_start, t_end, k)] of the identification phases, from the firmware's
        "ID k/n: name" events (a phase ends where the next one, "ID done" or
        "ID aborted" begins)."""
        out = []
        for t, _sev, text in self.events:
            ph = phase_of(text)
            if ph:
                if out and out[-1][2] is None:
                    out[-1][2] = t
                out.append([ph[2], t, None, ph[0]])
            elif text == "ID done" or text.startswith("ID aborted") or text.startswith("Mode "):
                if out and out[-1][2] is None and not text == "Mode EXPERIMENT":
                    out[-1][2] = t
        end = self.fw.t[-1] if self.fw is not None else (self.truth.t[-1] if self.truth else 0.0)
        return [(n, a, b if b is not None else end, k) for n, a, b, k in out]

    def phase_windows(self, *words):
        """Phases whose name contains any of `words` (case-insensitive)."""
        words = [w.lower() for w in words]
        return [p for p in self.phases() if any(w in p[0].lower() for w in words)]


def find_logs(paths):
    """LOG arguments -> files: a directory stands for the *.lcm files in it."""
    files = []
    for p in paths:
        if os.path.isdir(p):
            found = sorted(os.path.join(p, f) for f in os.listdir(p) if f.endswith(".lcm"))
            if not found:
                raise GcsError(f"no .lcm files in {p}")
            files += found
        elif os.path.exists(p):
            files.append(p)
        else:
            raise GcsError(f"no such log: {p}")
    return files


class LogTail:
    """Follows an LCM log being written: the plant time of its last complete record."""

    def __init__(self, path):
        self.path = path
        self.off = 0
        self.t = None
        self._f = None

    def time(self):
        if self._f is None:
            try:
                self._f = open(self.path, "rb")
            except OSError:
                return self.t
        self._f.seek(self.off)
        buf = self._f.read()
        off = 0
        while off + _HDR.size <= len(buf):
            sync, _num, utime, clen, dlen = _HDR.unpack_from(buf, off)
            if sync != SYNC:
                break
            end = off + _HDR.size + clen + dlen
            if end > len(buf):
                break
            self.t = utime * 1e-6
            off = end
        self.off += off
        return self.t

    def close(self):
        if self._f is not None:
            self._f.close()
            self._f = None
