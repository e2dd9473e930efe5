"""Vehicle files in octo-sim's JSON format (``octo-sim --vehicle``): the truth.

Absent keys keep the paper's defaults (the same as octo-sim's). Only the keys the
ground station needs are checked in depth here; octo-sim checks the whole file
strictly when it loads it.
"""

import json
import math

PAPER = {  # Table 1 of the paper and its Section 5
    "kf": 28.0269,
    "ktau": 0.3869,
    "inertia": [0.0628, 0.0762, 0.1014],
    "mass": 2.132,
    "g": 9.796,
}

DEFAULTS = {
    "mass": 2.132,
    "g": 9.796,
    "arm_length": 0.35,
    "kf": 28.0269,
    "ktau": 0.3869,
    "inertia": [0.0628, 0.0762, 0.1014],
    "motor_tau": 0.03,
    "delay": 0.0,
    "thrust_curve": 0.0,
    "rotor_scale": [1.0] * 8,
    "kf_drift_per_min": 0.0,
}

# octo-sim's other keys: the noise and sensor models (docs/sensors.md), the plant's faults
OBJECTS = {  # an object's keys
    "noise": ("thrust", "torque", "gyro", "attitude_deg", "position", "accel", "rpm", "current"),
    "imu_bias": ("accel", "gyro", "accel_walk", "gyro_walk"),
    "vibration": ("accel", "gyro", "harmonics", "cutoff_hz", "sample_hz"),
    "imu_spike": ("prob", "gyro", "accel"),
}
# the plant's events at a plant time: one object or a list of them, their keys and whether required
EVENTS = {
    "rotor_failure": {"rotor": True, "at_s": True, "scale": False},
    "stuck_rpm": {"rotor": True, "at_s": True},
}
OTHER = (
    "origin",
    "origin_shift_s",
    "imu_scale",
    "rpm_max",
    "esc_pole_pairs",
    "esc_kt",
    "esc_current_offset",
    "sensors",
)
SENSORS = ("imu", "rpm", "torque", "thrust")
KNOWN = set(DEFAULTS) | set(OBJECTS) | set(OTHER) | set(EVENTS)
PLANT_TIME_MAX_S = 1e9


class VehicleFileError(ValueError):
    pass


def _positive(path, key, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise VehicleFileError(f"{path}: key '{key}' must be a positive number")
    return float(v)


def _number(path, key, v, lo, hi, integer=False):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and lo <= v <= hi
    if ok and integer and v != int(v):
        ok = False
    if not ok:
        what = "an integer" if integer else "a number"
        raise VehicleFileError(f"{path}: key '{key}' must be {what} in [{lo:g}, {hi:g}], not {json.dumps(v)}")
    return v


def _events(path, key, value):
    """Checks a plant event (rotor_failure, stuck_rpm): one object or a non-empty list of them."""
    names = EVENTS[key]
    items = value if isinstance(value, list) else [value]
    if not items:
        raise VehicleFileError(f"{path}: key '{key}' must be an object or a non-empty list of objects")
    for e in items:
        if not isinstance(e, dict):
            raise VehicleFileError(
                f"{path}: key '{key}' must be an object {{{', '.join(names)}}} or a list of them"
            )
        bad = sorted(set(e) - set(names))
        if bad:
            raise VehicleFileError(f"{path}: unknown key '{key}.{bad[0]}' (known: {', '.join(names)})")
        for k, required in names.items():
            if required and k not in e:
                raise VehicleFileError(f"{path}: key '{key}' needs '{k}'")
        _number(path, f"{key}.rotor", e["rotor"], 1, 8, integer=True)
        _number(path, f"{key}.at_s", e["at_s"], 0, PLANT_TIME_MAX_S)
        if "scale" in e:
            _number(path, f"{key}.scale", e["scale"], 0, 1)


def parse(text, path="<vehicle>"):
    """Vehicle dict (defaults filled in) from the JSON text."""
    try:
        raw = json.loads(text)
    except ValueError as e:
        raise VehicleFileError(f"{path}: not valid JSON: {e}") from None
    if not isinstance(raw, dict):
        raise VehicleFileError(f"{path}: the vehicle file must hold one JSON object")
    unknown = sorted(set(raw) - KNOWN)
    if unknown:
        raise VehicleFileError(f"{path}: unknown key '{unknown[0]}' (known: {', '.join(sorted(KNOWN))})")
    for key, names in OBJECTS.items():
        if key not in raw:
            continue
        if not isinstance(raw[key], dict):
            raise VehicleFileError(f"{path}: key '{key}' must be an object")
        bad = sorted(set(raw[key]) - set(names))
        if bad:
            raise VehicleFileError(f"{path}: unknown key '{key}.{bad[0]}' (known: {', '.join(names)})")
    for key in EVENTS:
        if key in raw:
            _events(path, key, raw[key])
    for k, v in (raw.get("imu_spike") or {}).items():
        if k == "prob":
            _number(path, "imu_spike.prob", v, 0, 1)
        else:
            _positive(path, f"imu_spike.{k}", v)
    if "sensors" in raw:
        sensors = raw["sensors"]
        if not isinstance(sensors, list) or not sensors:
            raise VehicleFileError(
                f"{path}: key 'sensors' must be a non-empty list from {', '.join(SENSORS)}"
            )
        for x in sensors:
            if x not in SENSORS:
                raise VehicleFileError(
                    f"{path}: key 'sensors': unknown sensor {json.dumps(x)} (known: {', '.join(SENSORS)})"
                )
    v = json.loads(json.dumps(DEFAULTS))
    v.update(raw)
    for key in ("mass", "arm_length", "kf", "ktau"):
        v[key] = _positive(path, key, v[key])
    inertia = v["inertia"]
    if not isinstance(inertia, list) or len(inertia) != 3:
        raise VehicleFileError(f"{path}: key 'inertia' must be an array of 3 numbers")
    v["inertia"] = [_positive(path, "inertia", x) for x in inertia]
    return v


def load(path):
    """Vehicle dict from FILE, or the defaults when path is None."""
    if path is None:
        return parse("{}", "<defaults>")
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError as e:
        raise VehicleFileError(f"cannot read vehicle file {path}: {e.strerror}") from None
    return parse(text, str(path))


def truth_of(v):
    """The identified quantities' true values: {kf, ktau, ixx, iyy, izz}."""
    return {
        "kf": v["kf"],
        "ktau": v["ktau"],
        "ixx": v["inertia"][0],
        "iyy": v["inertia"][1],
        "izz": v["inertia"][2],
    }
