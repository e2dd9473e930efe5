"""Identification results as data: the firmware's OCTO_ID_RESULT records.

octo-fw publishes each result of an experiment as the MAVLink message OCTO_ID_RESULT (dialect
octo) and as the LCM record octo.fw_id_result_t on channel OCTO_FW_ID_RESULT (fw.lcm); both carry
the same fields (run_id, index, count, run_done, experiment, param, rotor, value, sd, accepted,
reason, source) with the codes of the dialect's enums OCTO_ID_PARAM, OCTO_ID_REASON and
OCTO_ID_SOURCE. This module turns such records into the ID_* values the report and the checks
use, and names their reasons and sources with the enums' entries.
"""

import math

from .quantities import QUANTITIES

FIELDS = (
    "run_id",
    "index",
    "count",
    "run_done",
    "experiment",
    "param",
    "rotor",
    "value",
    "sd",
    "accepted",
    "reason",
    "source",
)

NOT_IDENTIFIABLE = "not_identifiable"  # OCTO_ID_REASON_NOT_IDENTIFIABLE's name

# OCTO_ID_PARAM -> (parameter of the estimate, parameter of its sd; None: not a parameter)
_PARAMS = {
    "KF": ("ID_KF_EST", "ID_KF_SD"),
    "KTAU": ("ID_KTAU_EST", "ID_KTAU_SD"),
    "IXX": ("ID_IXX_EST", "ID_IXX_SD"),
    "IYY": ("ID_IYY_EST", "ID_IYY_SD"),
    "IZZ": ("ID_IZZ_EST", "ID_IZZ_SD"),
    "MOT_TAU": ("ID_TAU_CHECK", "ID_TAU_SD"),
    "DELAY_FR": ("ID_DELAY_FR", None),
    "MOT_CURVE": ("MOT_CURVE", "ID_CRV_SD"),
    "KF_PLAIN": ("ID_KF_PLAIN", None),
    "KTAU_PLAIN": ("ID_KTAU_PLAIN", None),
    "KTAU_OVER_IZZ": ("ID_KTIZ", "ID_KTIZ_SD"),
    "VAL_NE_BEFORE": ("ID_VAL_NE_PRE", "ID_VAL_FIT_PRE"),  # the fit % travels in sd's place
    "VAL_NE_AFTER": ("ID_VAL_NE_POST", "ID_VAL_FIT_POST"),
}
# OCTO_ID_PARAM of each identified quantity (report.json's keys)
QUANTITY_PARAM = {"kf": "KF", "ktau": "KTAU", "ixx": "IXX", "iyy": "IYY", "izz": "IZZ"}


def _enum(name):
    """{code: entry name without its prefix, lower case} of one of the dialect's enums."""
    from pymavlink.dialects.v20 import octo

    prefix = name + "_"
    return {
        code: e.name[len(prefix) :].lower()
        for code, e in octo.enums[name].items()
        if e.name.startswith(prefix)
    }


_names = {}


def _name(enum, code):
    if enum not in _names:
        _names[enum] = _enum(enum)
    return _names[enum].get(int(code), f"{enum.lower()} {int(code)}")


def param_name(code):
    """'kf', 'mot_scale', ... for an OCTO_ID_PARAM code."""
    return _name("OCTO_ID_PARAM", code)


def reason_name(code):
    """'ok', 'uncertain', 'model', ... for an OCTO_ID_REASON code."""
    return _name("OCTO_ID_REASON", code)


def source_name(code):
    """'thrust', 'imu', 'imu_rpm', 'imu_rpm_torque' or 'unknown' for an OCTO_ID_SOURCE code."""
    return _name("OCTO_ID_SOURCE", code)


def record(msg):
    """The fields of an OCTO_ID_RESULT message or an octo.fw_id_result_t record as a dict."""
    rec = {f: getattr(msg, f) for f in FIELDS}
    for f in FIELDS:
        rec[f] = float(rec[f]) if f in ("value", "sd") else int(rec[f])
    return rec


class Collector:
    """The results of identification runs, one per (run_id, index), as they arrive (a
    message sent again replaces its first copy)."""

    def __init__(self):
        self._by_key = {}

    def add(self, msg):
        rec = msg if isinstance(msg, dict) else record(msg)
        self._by_key[(rec["run_id"], rec["index"])] = rec

    def records(self):
        return [self._by_key[k] for k in sorted(self._by_key)]

    def runs(self):
        return sorted({run for run, _ in self._by_key})

    def missing(self, run_id):
        """Indices of run `run_id` not received, or None while its end (run_done) is unknown."""
        have = {i: r for (run, i), r in self._by_key.items() if run == run_id}
        done = [r for r in have.values() if r["run_done"]]
        if not done:
            return None
        return [i for i in range(done[0]["count"]) if i not in have]

    def __len__(self):
        return len(self._by_key)


def _latest(records):
    """The last record of each (param, rotor), in the order given."""
    out = {}
    for rec in records:
        out[(rec["param"], rec["rotor"])] = rec
    return out


def _finite(x):
    return x is not None and math.isfinite(x)


def to_params(records):
    """The ID_* (and motor model) values the records state, by parameter name, with ID_RESULT's
    bits from their accepted flags (a bit set when every result of its quantities is accepted)."""
    out = {}
    latest = _latest(records)
    for (code, rotor), rec in latest.items():
        name = param_name(code)
        if name == "mot_scale":
            if 1 <= rotor <= 8:
                out[f"MOT_SCALE{rotor}"] = rec["value"]
            continue
        est, sd = _PARAMS.get(name.upper(), (None, None))
        if est is None:
            continue
        out[est] = rec["value"]
        if sd is not None and _finite(rec["sd"]):
            out[sd] = rec["sd"]
    bits, seen = 0, 0
    by_param = {param_name(code): rec for (code, _rotor), rec in latest.items()}
    for bit in sorted({q.bit for q in QUANTITIES}):
        recs = [by_param.get(QUANTITY_PARAM[q.key].lower()) for q in QUANTITIES if q.bit == bit]
        # a quantity the data cannot determine (only a ratio) has no part in its bit
        recs = [r for r in recs if r is not None and reason_name(r["reason"]) != NOT_IDENTIFIABLE]
        if recs:
            seen |= bit
            if all(r["accepted"] for r in recs):
                bits |= bit
    if seen:
        out["ID_RESULT"] = float(bits)
    return out


def merge(params, records):
    """params plus the values only the records carry; returns (merged, the names filled in)."""
    extra = {k: v for k, v in to_params(records).items() if k not in params}
    merged = dict(params)
    merged.update(extra)
    return merged, sorted(extra)


def verdicts(records):
    """{quantity key: {"accepted", "reason", "source"}} of the identified quantities' last results."""
    by_param = {param_name(code): rec for (code, _rotor), rec in _latest(records).items()}
    out = {}
    for key, p in QUANTITY_PARAM.items():
        rec = by_param.get(p.lower())
        if rec is not None:
            out[key] = {
                "accepted": bool(rec["accepted"]),
                "reason": reason_name(rec["reason"]),
                "source": source_name(rec["source"]),
            }
    return out


def not_identifiable(records):
    """The quantity keys whose last result says the data cannot determine them alone (the
    IMU source: k_tau and I_z, of which only the ratio k_tau / I_z is identified)."""
    return {k for k, v in verdicts(records).items() if v["reason"] == NOT_IDENTIFIABLE}


def ratio_verdict(records):
    """{"value", "sd", "accepted", "reason", "source"} of the last k_tau / I_z result (None
    without one)."""
    recs = [r for r in records if param_name(r["param"]) == "ktau_over_izz"]
    if not recs:
        return None
    rec = recs[-1]
    return {
        "value": rec["value"] if _finite(rec["value"]) else None,
        "sd": rec["sd"] if _finite(rec["sd"]) else None,
        "accepted": bool(rec["accepted"]),
        "reason": reason_name(rec["reason"]),
        "source": source_name(rec["source"]),
    }


def estimator_source(records):
    """The measurements the estimates rest on: the k_f result's source, else the first stated one."""
    v = verdicts(records)
    if "kf" in v and v["kf"]["source"] != "unknown":
        return v["kf"]["source"]
    for rec in records:
        name = source_name(rec["source"])
        if name != "unknown":
            return name
    return None


# OCTO_ID_SOURCE's entries in words (report.md, the printed table, campaign.md)
SOURCE_WORDS = {
    "thrust": "thrust rows",
    "imu": "IMU",
    "imu_rpm": "IMU and rotor speed",
    "imu_rpm_torque": "IMU, rotor speed and ESC torque",
}


# the plant's sensors (octo-sim --sensors) each source's estimates rest on
SOURCE_SENSORS = {
    "thrust": ("thrust", "torque"),
    "imu": ("imu",),
    "imu_rpm": ("imu", "rpm"),
    "imu_rpm_torque": ("imu", "rpm", "torque"),
}


def source_words(name):
    """'thrust rows', 'IMU', ... for a source name (the name itself when it has no words;
    'not stated' for None)."""
    if not name:
        return "not stated"
    return SOURCE_WORDS.get(name, name)


def rejections(records):
    """{quantity key: reason} of the identified quantities whose last result was not accepted."""
    out = {}
    for key, v in verdicts(records).items():
        if not v["accepted"]:
            out[key] = v["reason"]
    return out


def describe(rec):
    """One result as data for report.json (names instead of codes)."""
    return {
        "run_id": rec["run_id"],
        "index": rec["index"],
        "experiment": rec["experiment"],
        "param": param_name(rec["param"]),
        "rotor": rec["rotor"],
        "value": rec["value"] if _finite(rec["value"]) else None,
        "sd": rec["sd"] if _finite(rec["sd"]) else None,
        "accepted": bool(rec["accepted"]),
        "reason": reason_name(rec["reason"]),
        "source": source_name(rec["source"]),
    }
