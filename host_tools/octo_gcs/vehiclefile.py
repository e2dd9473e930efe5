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
KNOWN = set(DEFAULTS) | set(OBJECTS) | set(OTHER)


class VehicleFileError(ValueError):
    pass


def _positive(path, key, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise VehicleFileError(f"{path}: key '{key}' must be a positive number")
    return float(v)


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
