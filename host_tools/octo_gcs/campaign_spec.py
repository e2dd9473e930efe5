"""Campaign specifications (``octo-gcs campaign SPEC.json``): validation and draws.

A spec is one JSON object::

    {"name": "default", "missions": 100, "seed": 1,
     "vehicle": {"kf": {"uniform": [16.8, 39.2]}, "inertia": [{"normal": [0.0628, 0.005]}, 0.0762, 0.1014],
                 "noise": {"gyro": {"uniform": [0.005, 0.025]}}},
     "faults": {"drop": {"choice": [0, 0.02]}},
     "params": {"ID_INR_TIME": 20},
     "experiments": [6], "plant": "in-process", "build": {"choice": ["float", "fixed"]},
     "sensors": "imu,rpm", "timeout": 600, "retries": 2,
     "tolerance_pct": {"kf": 0.3}, "expect": {"k_f_error_pct": 0.3, "silently_wrong": 0}}

A value is a number or a draw: ``{"uniform": [lo, hi]}``, ``{"loguniform": [lo, hi]}`` (0 < lo),
``{"normal": [mean, sd]}`` or ``{"choice": [v1, v2, ...]}``. Mission i (0-based) flies with seed
``seed + i``; every drawn value comes from its own generator seeded by (seed, i, the value's path),
so a mission's draws depend on the spec alone, not on the order in which missions run, nor on
which other keys the spec draws: two specs that differ only in ``build`` or ``sensors`` fly the
same vehicles, mission by mission.

``build`` ("float" or "fixed", the firmware's arithmetic) and ``sensors`` (what the plant serves:
a list such as ``["imu", "rpm"]`` or the text ``"imu,rpm"``; absent: all) are words, fixed or
drawn with ``{"choice": [...]}``; so is the vehicle's own ``sensors`` list.

``sensors`` as a list of sensor lists (``[["imu", "rpm", "torque", "thrust"], ["imu"]]``) flies
every vehicle once with each set: ``missions`` counts the vehicles, the campaign flies
missions x sets. Flight i flies vehicle i // sets (its draws, its seed ``seed + i // sets``)
with set i % sets; the column ``vehicle`` pairs the flights of one vehicle, so campaign.md
compares each source's estimates with the same vehicle's thrust-row estimates.

The plant's events ``vehicle.rotor_failure`` and ``vehicle.stuck_rpm`` are one object whose
values are drawn (``{"rotor": {"choice": [1, 2, ..., 8]}, "at_s": {"uniform": [20, 60]},
"scale": 0, "probability": 0.3}``): with ``probability`` (default 1) the mission's vehicle file
gets the event, and the column ``vehicle.rotor_failure.on`` says whether it did.

Validation happens before anything runs; every error names the key (``vehicle.inertia[1]``).
"""

import json
import math
import re
import zlib

import numpy as np

from .mission.options import BUILDS, FAULTS, SENSORS
from .vehiclefile import DEFAULTS as VEHICLE_DEFAULTS

DISTRIBUTIONS = ("uniform", "loguniform", "normal", "choice")

# octo-sim's vehicle keys: scalars, per-element lists (their length) and the noise object
VEHICLE_SCALARS = (
    "mass",
    "g",
    "arm_length",
    "kf",
    "ktau",
    "motor_tau",
    "delay",
    "thrust_curve",
    "kf_drift_per_min",
    "imu_scale",
    "rpm_max",
    "esc_pole_pairs",
    "esc_kt",
    "esc_current_offset",
)
VEHICLE_INTEGERS = ("esc_pole_pairs",)
VEHICLE_LISTS = {"inertia": 3, "rotor_scale": 8, "origin": 3}
# lists of any length (at least one value): plant times of an origin shift
VEHICLE_VARLISTS = {"origin_shift_s": (0, 1e9, True)}
NOISE_KEYS = ("thrust", "torque", "gyro", "attitude_deg", "position", "accel", "rpm", "current")
# the vehicle's objects of numbers: their keys and ranges (vibration.harmonics: a list of 1 to 4)
VEHICLE_OBJECTS = {
    "noise": {k: (0, None, True) for k in NOISE_KEYS},
    "imu_bias": {k: (0, None, True) for k in ("accel", "gyro", "accel_walk", "gyro_walk")},
    "vibration": {
        "accel": (0, None, True),
        "gyro": (0, None, True),
        "harmonics": (0, None, True),
        "cutoff_hz": (0, None, False),
        "sample_hz": (100, 32000, True),
    },
    "imu_spike": {"prob": (0, 1, True), "gyro": (0, None, False), "accel": (0, None, False)},
}
# the plant's events at a plant time (one per mission, drawn): their keys and ranges; "rotor" is
# a whole number. "probability" (a number in [0, 1], default 1) is the spec's: the share of
# missions that have the event (the draw is the column vehicle.KEY.on, 1 or 0).
VEHICLE_EVENTS = {
    "rotor_failure": {"rotor": (1, 8, True), "at_s": (0, 1e9, True), "scale": (0, 1, True)},
    "stuck_rpm": {"rotor": (1, 8, True), "at_s": (0, 1e9, True)},
}
EVENT_REQUIRED = ("rotor", "at_s")
HARMONICS_MAX = 4
# octo-sim's defaults that a cross-check needs (vibration.cutoff_hz < 0.45 vibration.sample_hz)
VIBRATION_DEFAULTS = {"cutoff_hz": 30.0, "sample_hz": 1000.0}
# the range octo-sim accepts for a vehicle value (checked on the spec's bounds and on every draw)
VEHICLE_RANGE = {
    "mass": (0, None, False),
    "g": (0, None, False),
    "arm_length": (0, None, False),
    "kf": (0, None, False),
    "ktau": (0, None, False),
    "inertia": (0, None, False),
    "motor_tau": (0, None, True),
    "delay": (0, 10, True),
    "thrust_curve": (0, 1, True),
    "rotor_scale": (0, None, True),
    "kf_drift_per_min": (None, None, True),
    "origin": (None, None, True),
    "imu_scale": (0, 0.2, True),
    "rpm_max": (0, None, False),
    "esc_pole_pairs": (1, 64, True),
    "esc_kt": (0, None, False),
    "esc_current_offset": (None, None, True),
}

TOP_KEYS = (
    "name",
    "missions",
    "seed",
    "vehicle",
    "faults",
    "params",
    "experiments",
    "plant",
    "build",
    "sensors",
    "timeout",
    "retries",
    "tolerance_pct",
    "expect",
)

# the identified quantities' other names in `expect`, default tolerances
ALIASES = {
    "kf": "kf",
    "k_f": "kf",
    "ktau": "ktau",
    "k_tau": "ktau",
    "ixx": "ixx",
    "i_x": "ixx",
    "iyy": "iyy",
    "i_y": "iyy",
    "izz": "izz",
    "i_z": "izz",
    "ktiz": "ktiz",
    "ktau_over_izz": "ktiz",
    "k_tau/i_z": "ktiz",
}
# ktiz: k_tau / I_z, identified in their place by a source without ESC torque
DEFAULT_TOL_PCT = {"kf": 0.3, "ktau": 0.3, "ixx": 2.0, "iyy": 2.0, "izz": 2.0, "ktiz": 2.0}
EXPECT_SUFFIXES = ("_error_pct", "_acceptance")
EXPECT_PLAIN = ("silently_wrong", "acceptance", "failures")
PARAM_NAME = re.compile(r"^[A-Z][A-Z0-9_]{0,15}$")


class SpecError(ValueError):
    """A spec that cannot run; the message names the key."""


def _is_num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _check_range(path, v, rng):
    lo, hi, zero_ok = rng
    if lo is not None and (v < lo or (v == lo and not zero_ok)):
        raise SpecError(f"{path}: {v:g} is out of range (must be {'>=' if zero_ok else '>'} {lo:g})")
    if hi is not None and v > hi:
        raise SpecError(f"{path}: {v:g} is out of range (must be <= {hi:g})")


def _check_value(path, v, rng=None, integer=False):
    """A number or a valid draw; bounds of a uniform/loguniform/choice checked against rng."""
    if _is_num(v):
        if rng:
            _check_range(path, v, rng)
        if integer and v != int(v):
            raise SpecError(f"{path}: must be a whole number, not {v}")
        return
    if not isinstance(v, dict):
        raise SpecError(
            f'{path}: must be a number or a draw such as {{"uniform": [lo, hi]}}, not {json.dumps(v)}'
        )
    if len(v) != 1:
        raise SpecError(f"{path}: a draw has exactly one of {', '.join(DISTRIBUTIONS)}; got {sorted(v)}")
    ((dist, a),) = v.items()
    if dist not in DISTRIBUTIONS:
        raise SpecError(f"{path}: unknown distribution '{dist}' (known: {', '.join(DISTRIBUTIONS)})")
    where = f"{path}.{dist}"
    if dist == "choice":
        if not isinstance(a, list) or not a:
            raise SpecError(f"{where}: must be a non-empty list of numbers")
        for j, x in enumerate(a):
            if not _is_num(x):
                raise SpecError(f"{where}[{j}]: must be a number, not {json.dumps(x)}")
            _check_value(f"{where}[{j}]", x, rng, integer)
        return
    if not isinstance(a, list) or len(a) != 2 or not all(_is_num(x) for x in a):
        raise SpecError(f"{where}: must be [two numbers], not {json.dumps(a)}")
    lo, hi = a
    if dist == "normal":
        if hi < 0:
            raise SpecError(f"{where}: the standard deviation {hi:g} is negative")
        if rng and hi == 0:
            _check_range(path, lo, rng)
        return  # an unbounded draw: check_all_draws checks every value drawn
    if hi < lo:
        raise SpecError(f"{where}: empty range [{lo:g}, {hi:g}] (lo > hi)")
    if dist == "loguniform" and lo <= 0:
        raise SpecError(f"{where}: needs 0 < lo, got {lo:g}")
    if rng:
        _check_range(path, lo, rng)
        _check_range(path, hi, rng)


def _walk(spec):
    """(path, value, rng, integer, target) of every value of the spec, in a fixed order.
    target: ("vehicle", key, index or noise key or None) | ("faults", key) | ("params", name)."""
    out = []
    veh = spec.get("vehicle", {})
    for k in sorted(veh):
        if k == "sensors":
            continue  # a word: _words
        if k in VEHICLE_LISTS or k in VEHICLE_VARLISTS:
            rng = VEHICLE_RANGE.get(k) or VEHICLE_VARLISTS[k]
            for j, x in enumerate(veh[k]):
                out.append((f"vehicle.{k}[{j}]", x, rng, False, ("vehicle", k, j)))
        elif k in VEHICLE_EVENTS:
            for nk in sorted(veh[k]):
                if nk != "probability":
                    rng = VEHICLE_EVENTS[k][nk]
                    out.append((f"vehicle.{k}.{nk}", veh[k][nk], rng, nk == "rotor", ("vehicle", k, nk)))
        elif k in VEHICLE_OBJECTS:
            for nk in sorted(veh[k]):
                rng = VEHICLE_OBJECTS[k][nk]
                if k == "vibration" and nk == "harmonics":
                    for j, x in enumerate(veh[k][nk]):
                        out.append((f"vehicle.{k}.{nk}[{j}]", x, rng, False, ("vehicle", k, (nk, j))))
                else:
                    out.append((f"vehicle.{k}.{nk}", veh[k][nk], rng, False, ("vehicle", k, nk)))
        else:
            integer = k in VEHICLE_INTEGERS
            out.append((f"vehicle.{k}", veh[k], VEHICLE_RANGE[k], integer, ("vehicle", k, None)))
    for k in sorted(spec.get("faults", {})):
        _flag, integer, lo, hi = FAULTS[k]
        out.append((f"faults.{k}", spec["faults"][k], (lo, hi, True), integer, ("faults", k)))
    for k in sorted(spec.get("params", {})):
        out.append((f"params.{k}", spec["params"][k], None, False, ("params", k)))
    return out


def _build_word(path, v):
    if v not in BUILDS:
        raise SpecError(f"{path}: {json.dumps(v)} is not a build (known: {', '.join(BUILDS)})")
    return v


def _sensors_word(path, v):
    """The sensor names of a list or a comma-separated text, in SENSORS' order."""
    names = v.split(",") if isinstance(v, str) else v
    if not isinstance(names, list) or not names or not all(isinstance(x, str) for x in names):
        raise SpecError(
            f'{path}: must be a list of sensors such as ["imu", "rpm"] or a text "imu,rpm", not {json.dumps(v)}'
        )
    for x in names:
        if x.strip() not in SENSORS:
            raise SpecError(f"{path}: unknown sensor {json.dumps(x)} (known: {', '.join(SENSORS)})")
    chosen = {x.strip() for x in names}
    return [x for x in SENSORS if x in chosen]


def _is_sets(v):
    """`sensors` as a list of sensor lists: every vehicle flies once with each."""
    return isinstance(v, list) and bool(v) and all(isinstance(x, list) for x in v)


def sensor_sets(spec):
    """The sensor sets every vehicle flies with (lists of names), or None (one flight each)."""
    v = spec.get("sensors")
    if not _is_sets(v):
        return None
    return [_sensors_word(f"sensors[{j}]", x) for j, x in enumerate(v)]


def flights(spec):
    """The campaign's missions: one per vehicle, or one per vehicle and sensor set."""
    sets = sensor_sets(spec)
    return spec["missions"] * (len(sets) if sets else 1)


def vehicle_of(spec, index):
    """(vehicle, sensor set) of flight `index`: the vehicle whose draws it flies and the index of
    its sensor set (0 without sets)."""
    sets = sensor_sets(spec)
    return (index // len(sets), index % len(sets)) if sets else (index, 0)


def _check_word(path, v, word):
    """A word (checked by word(path, v)) or {"choice": [words]}."""
    if isinstance(v, dict):
        if set(v) != {"choice"}:
            raise SpecError(f'{path}: a value or {{"choice": [...]}}, not {json.dumps(v)}')
        a = v["choice"]
        if not isinstance(a, list) or not a:
            raise SpecError(f"{path}.choice: must be a non-empty list")
        for j, x in enumerate(a):
            word(f"{path}.choice[{j}]", x)
        return
    word(path, v)


def _check_vibration(vib):
    """octo-sim's cross-check: vibration.cutoff_hz < 0.45 vibration.sample_hz, on the bounds
    (a draw's every value is checked by check_all_draws)."""

    def bounds(key):
        v = vib.get(key, VIBRATION_DEFAULTS[key])
        if _is_num(v):
            return v, v
        ((dist, a),) = v.items()
        return (min(a), max(a)) if dist != "normal" else (None, None)

    cut_hi = bounds("cutoff_hz")[1]
    rate_lo = bounds("sample_hz")[0]
    if cut_hi is not None and rate_lo is not None and not cut_hi < 0.45 * rate_lo:
        raise SpecError(
            f"vehicle.vibration.cutoff_hz: {cut_hi:g} is out of range (must be < 0.45 vibration.sample_hz "
            f"= {0.45 * rate_lo:g} Hz)"
        )


def validate(spec):
    """Checks a parsed spec; returns it with defaults filled in. Raises SpecError."""
    if not isinstance(spec, dict):
        raise SpecError("the spec must be one JSON object")
    for k in spec:
        if k not in TOP_KEYS:
            raise SpecError(f"unknown key '{k}' (known: {', '.join(TOP_KEYS)})")
    s = dict(spec)
    s.setdefault("name", "campaign")
    if not isinstance(s["name"], str) or not s["name"]:
        raise SpecError("name: must be a non-empty string")
    if "missions" not in s:
        raise SpecError("missions: missing (the number of missions, >= 1)")
    s.setdefault("seed", 1)
    for k, lo in (("missions", 1), ("seed", 0)):
        if not isinstance(s[k], int) or isinstance(s[k], bool) or s[k] < lo:
            raise SpecError(f"{k}: must be a whole number >= {lo}, not {json.dumps(s[k])}")
    if s["seed"] + s["missions"] > 2**31 - 1:
        raise SpecError("seed: seed + missions must stay below 2^31")
    for k in ("vehicle", "faults", "params", "tolerance_pct", "expect"):
        s.setdefault(k, {})
        if not isinstance(s[k], dict):
            raise SpecError(f"{k}: must be an object")
    for k, v in s["vehicle"].items():
        if k in VEHICLE_OBJECTS:
            names = VEHICLE_OBJECTS[k]
            if not isinstance(v, dict):
                raise SpecError(f"vehicle.{k}: must be an object of numbers or draws")
            for nk in v:
                if nk not in names:
                    raise SpecError(f"vehicle.{k}: unknown key '{nk}' (known: {', '.join(names)})")
            h = v.get("harmonics", []) if k == "vibration" else []
            if not isinstance(h, list) or ("harmonics" in v and not 1 <= len(h) <= HARMONICS_MAX):
                raise SpecError(
                    f"vehicle.vibration.harmonics: must be a list of 1 to {HARMONICS_MAX} numbers or draws"
                )
        elif k in VEHICLE_EVENTS:
            names = VEHICLE_EVENTS[k]
            if not isinstance(v, dict):
                raise SpecError(
                    f"vehicle.{k}: must be one object of numbers or draws ({', '.join(names)}, probability)"
                )
            for nk in v:
                if nk not in names and nk != "probability":
                    raise SpecError(
                        f"vehicle.{k}: unknown key '{nk}' (known: {', '.join(names)}, probability)"
                    )
            for nk in EVENT_REQUIRED:
                if nk not in v:
                    raise SpecError(
                        f"vehicle.{k}.{nk}: missing (the event needs {' and '.join(EVENT_REQUIRED)})"
                    )
            p = v.get("probability", 1)
            if not _is_num(p) or not 0 <= p <= 1:
                raise SpecError(f"vehicle.{k}.probability: must be a number in [0, 1], not {json.dumps(p)}")
        elif k in VEHICLE_LISTS:
            if not isinstance(v, list) or len(v) != VEHICLE_LISTS[k]:
                raise SpecError(f"vehicle.{k}: must be a list of {VEHICLE_LISTS[k]} numbers or draws")
        elif k in VEHICLE_VARLISTS:
            if not isinstance(v, list) or not v:
                raise SpecError(f"vehicle.{k}: must be a non-empty list of numbers or draws")
        elif k == "sensors":
            _check_word("vehicle.sensors", v, _sensors_word)
        elif k not in VEHICLE_SCALARS:
            known = sorted(
                set(VEHICLE_SCALARS)
                | set(VEHICLE_LISTS)
                | set(VEHICLE_VARLISTS)
                | set(VEHICLE_OBJECTS)
                | set(VEHICLE_EVENTS)
            )
            raise SpecError(f"vehicle: unknown key '{k}' (known: {', '.join(known + ['sensors'])})")
    for k in s["faults"]:
        if k not in FAULTS:
            raise SpecError(f"faults: unknown key '{k}' (known: {', '.join(FAULTS)})")
    for k in s["params"]:
        if not PARAM_NAME.match(k):
            raise SpecError(
                f"params: '{k}' is not a parameter name (capitals, digits, _; 16 characters at most)"
            )
        if k in ("VEH_MASS", "VEH_ARM_L"):
            raise SpecError(
                f"params.{k}: set by the mission from the vehicle's mass and arm length; "
                "draw vehicle.mass / vehicle.arm_length instead"
            )
    for path, v, rng, integer, _t in _walk(s):
        _check_value(path, v, rng, integer)
    if "vibration" in s["vehicle"]:
        _check_vibration(s["vehicle"]["vibration"])
    s.setdefault("experiments", [6])
    e = s["experiments"]
    if not isinstance(e, list) or not all(
        isinstance(x, int) and not isinstance(x, bool) and 1 <= x <= 6 for x in e
    ):
        raise SpecError(
            f"experiments: must be a list of experiment numbers 1..6 ([] only flies), not {json.dumps(e)}"
        )
    s.setdefault("plant", "in-process")
    if s["plant"] not in ("in-process", "udp"):
        raise SpecError(f'plant: must be "in-process" or "udp", not {json.dumps(s["plant"])}')
    s.setdefault("build", "float")
    _check_word("build", s["build"], _build_word)
    if "sensors" in s and _is_sets(s["sensors"]):
        seen = []
        for j, x in enumerate(s["sensors"]):
            names = _sensors_word(f"sensors[{j}]", x)
            if names in seen:
                raise SpecError(f"sensors[{j}]: the same set as sensors[{seen.index(names)}]")
            seen.append(names)
    elif "sensors" in s:
        _check_word("sensors", s["sensors"], _sensors_word)
    s.setdefault("timeout", 600)
    if not _is_num(s["timeout"]) or s["timeout"] <= 0:
        raise SpecError(f"timeout: must be a positive number of seconds, not {json.dumps(s['timeout'])}")
    s.setdefault("retries", 2)
    if not isinstance(s["retries"], int) or isinstance(s["retries"], bool) or s["retries"] < 0:
        raise SpecError(f"retries: must be a whole number >= 0, not {json.dumps(s['retries'])}")
    tol = dict(DEFAULT_TOL_PCT)
    for k, v in s["tolerance_pct"].items():
        q = ALIASES.get(k.lower())
        if q is None:
            raise SpecError(f"tolerance_pct: unknown parameter '{k}' (known: {', '.join(DEFAULT_TOL_PCT)})")
        if not _is_num(v) or v <= 0:
            raise SpecError(f"tolerance_pct.{k}: must be a positive number")
        tol[q] = float(v)
    s["tolerance_pct"] = tol
    for k, v in s["expect"].items():
        expect_key(k)
        if not _is_num(v) or v < 0:
            raise SpecError(f"expect.{k}: must be a number >= 0")
    return s


def expect_key(k):
    """(quantity or None, what) of an `expect` key; raises SpecError naming an unknown one."""
    if k in EXPECT_PLAIN:
        return None, k
    for suf in EXPECT_SUFFIXES:
        if k.endswith(suf):
            q = ALIASES.get(k[: -len(suf)].lower())
            if q:
                return q, suf[1:]
    raise SpecError(
        f"expect: unknown key '{k}' (known: PARAM_error_pct, PARAM_acceptance with PARAM one of "
        f"{', '.join(DEFAULT_TOL_PCT)} or k_f, k_tau, I_x, I_y, I_z, k_tau/I_z; {', '.join(EXPECT_PLAIN)})"
    )


def load(path):
    """The validated spec of FILE. Raises SpecError."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise SpecError(f"cannot read {path}: {e.strerror}") from None
    try:
        spec = json.loads(text)
    except ValueError as e:
        raise SpecError(f"{path}: not valid JSON: {e}") from None
    try:
        return validate(spec)
    except SpecError as e:
        raise SpecError(f"{path}: {e}") from None


def _generator(seed, index, path):
    return np.random.default_rng(np.random.SeedSequence([seed, index, zlib.crc32(path.encode())]))


def _draw(path, v, rng_bounds, integer, gen):
    if _is_num(v):
        x = float(v)
    else:
        ((dist, a),) = v.items()
        if dist == "uniform":
            x = float(gen.uniform(a[0], a[1]))
        elif dist == "loguniform":
            x = float(math.exp(gen.uniform(math.log(a[0]), math.log(a[1]))))
        elif dist == "normal":
            x = float(gen.normal(a[0], a[1]))
        else:
            x = float(a[int(gen.integers(len(a)))])
    if integer:
        x = int(round(x))
    if rng_bounds:
        try:
            _check_range(path, x, rng_bounds)
        except SpecError as e:
            raise SpecError(f"{e} (a draw of its normal distribution; narrow it)") from None
    return x


def _draw_word(spec, index, path, v, word):
    if isinstance(v, dict):
        a = v["choice"]
        v = a[int(_generator(spec["seed"], index, path).integers(len(a)))]
    return word(path, v)


def words(spec, index):
    """Mission `index`'s words: {"build": "float" | "fixed", "sensors": [names] or None (the spec
    does not say: the plant's default, or the vehicle's list), "vehicle.sensors": [names] or None}.
    With sensor sets, the build and the vehicle's list are its vehicle's, the sensors its set."""
    veh = spec.get("vehicle", {})
    sets = sensor_sets(spec)
    index, k = vehicle_of(spec, index)
    if sets:
        sensors = sets[k]
    elif "sensors" in spec:
        sensors = _draw_word(spec, index, "sensors", spec["sensors"], _sensors_word)
    else:
        sensors = None
    return {
        "build": _draw_word(spec, index, "build", spec.get("build", "float"), _build_word),
        "sensors": sensors,
        "vehicle.sensors": _draw_word(spec, index, "vehicle.sensors", veh["sensors"], _sensors_word)
        if "sensors" in veh
        else None,
    }


def draws(spec, index):
    """Mission `index`'s values: {path: value} for every value of the spec (drawn or fixed), and
    the words "build" and "sensors" (the sensors the plant serves, comma-separated, or "all");
    with sensor sets also "vehicle", the vehicle's number (its flights' values are the same)."""
    w = words(spec, index)
    served = w["sensors"] or w["vehicle.sensors"]
    out = {"build": w["build"], "sensors": ",".join(served) if served else "all"}
    if sensor_sets(spec):
        index = vehicle_of(spec, index)[0]
        out["vehicle"] = index
    if w["vehicle.sensors"] is not None:
        out["vehicle.sensors"] = ",".join(w["vehicle.sensors"])
    veh = spec.get("vehicle", {})
    for k in sorted(VEHICLE_EVENTS):
        if k in veh:
            path = f"vehicle.{k}.on"
            p = veh[k].get("probability", 1)
            out[path] = int(float(_generator(spec["seed"], index, path).uniform()) < p)
    out.update(
        {
            path: _draw(path, v, rng, integer, _generator(spec["seed"], index, path))
            for path, v, rng, integer, _t in _walk(spec)
        }
    )
    return out


def _check_drawn_vibration(d):
    cut = d.get("vehicle.vibration.cutoff_hz", VIBRATION_DEFAULTS["cutoff_hz"])
    rate = d.get("vehicle.vibration.sample_hz", VIBRATION_DEFAULTS["sample_hz"])
    if not cut < 0.45 * rate:
        raise SpecError(
            f"vehicle.vibration.cutoff_hz: {cut:g} is out of range (must be < 0.45 vibration.sample_hz "
            f"= {0.45 * rate:g} Hz) (a draw of its normal distribution; narrow it)"
        )


def mission_inputs(spec, index):
    """(seed, draws, vehicle dict for octo-sim, faults {name: value} (those that are on),
    params {NAME: value})."""
    d = draws(spec, index)
    index = vehicle_of(spec, index)[0]
    vehicle, faults, params = {}, {}, {}
    for path, _v, _rng, _integer, target in _walk(spec):
        x = d[path]
        if target[0] == "vehicle":
            _sec, key, sub = target
            if key in VEHICLE_LISTS:
                vehicle.setdefault(key, list(VEHICLE_DEFAULTS.get(key, [0.0] * VEHICLE_LISTS[key])))
                vehicle[key][sub] = x
            elif key in VEHICLE_VARLISTS:
                vehicle.setdefault(key, [0.0] * len(spec["vehicle"][key]))[sub] = x
            elif key == "vibration" and isinstance(sub, tuple):
                h = vehicle.setdefault(key, {}).setdefault(
                    "harmonics", [0.0] * len(spec["vehicle"][key]["harmonics"])
                )
                h[sub[1]] = x
            elif key in VEHICLE_EVENTS:
                vehicle.setdefault(key, {})[sub] = int(x) if sub == "rotor" else x
            elif key in VEHICLE_OBJECTS:
                vehicle.setdefault(key, {})[sub] = x
            elif key in VEHICLE_INTEGERS:
                vehicle[key] = int(x)
            else:
                vehicle[key] = x
        elif target[0] == "faults":
            if x != 0 or target[1] == "burst_prob":  # 0 is octo-sim's "off" (burst_prob: never)
                faults[target[1]] = int(x) if FAULTS[target[1]][1] else x
        else:
            params[target[1]] = x
    if d.get("vehicle.sensors"):
        vehicle["sensors"] = d["vehicle.sensors"].split(",")
    for k in VEHICLE_EVENTS:
        if not d.get(f"vehicle.{k}.on", 1):
            vehicle.pop(k, None)
    return spec["seed"] + index, d, vehicle, faults, params


def _check_drawn_inertia(spec, index, vehicle):
    """octo-sim's cross-check: each principal moment at most the sum of the other two."""
    inertia = vehicle.get("inertia")
    if not inertia:
        return
    for i in range(3):
        other = inertia[(i + 1) % 3] + inertia[(i + 2) % 3]
        if inertia[i] > other:
            raise SpecError(
                f"vehicle.inertia[{i}]: mission {index} draws {inertia[i]:g} > {other:g}, the sum of the other "
                "two (octo-sim refuses it: the triangle inequality); narrow the ranges"
            )


def check_all_draws(spec):
    """Makes every mission's draws once, so that a normal draw out of its key's range, or inertia
    that octo-sim would refuse, is an error before anything runs (cheap: no mission runs)."""
    sets = sensor_sets(spec)
    for i in range(0, flights(spec), len(sets) if sets else 1):
        _check_drawn_vibration(draws(spec, i))
        _check_drawn_inertia(spec, vehicle_of(spec, i)[0], mission_inputs(spec, i)[2])
