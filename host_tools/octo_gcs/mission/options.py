"""A mission's options, typed: what `octo-gcs mission` and a campaign's missions build."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Literal, Optional

from ..base import GcsError
from ..experiments import check_experiment, parse_experiments

TAKEOFF_M = 10.0  # the height of every mission's take-off and hold

# octo-sim's (and octo-sil's) fault injection flags: name -> (flag, integer, lo, hi)
FAULTS = {
    "drop": ("--drop", False, 0.0, 1.0),
    "burst": ("--burst", True, 0, 1000000),
    "burst_prob": ("--burst-prob", False, 0.0, 1.0),
    "delay_frames": ("--delay-frames", True, 0, 100000),
    "duplicate": ("--duplicate", False, 0.0, 1.0),
    "reorder": ("--reorder", False, 0.0, 1.0),
    "imu_spike": ("--imu-spike", False, 0.0, 1.0),
    "imu_spike_gyro": ("--imu-spike-gyro", False, 1e-6, 1e6),
    "imu_spike_accel": ("--imu-spike-accel", False, 1e-6, 1e6),
}

PLANTS = ("udp", "sil")
BUILDS = ("float", "fixed")  # the firmware's arithmetic: octo-fw / octo-sil, or their Q16.16 -fixed builds
SENSORS = ("imu", "rpm", "torque", "thrust")  # what the plant can serve (octo-sim --sensors)
PLANT_TIME_MAX_S = 1e9  # octo-sim's bound on --start-time and --shift-origin


@dataclass
class MissionOptions:
    """plant "udp": octo-sim and octo-fw over UDP, the ground station over MAVLink;
    plant "sil": octo-sil, firmware and plant in one deterministic lockstep process."""

    plant: Literal["udp", "sil"] = "udp"
    vehicle: Optional[str] = None  # octo-sim's vehicle file (None: the paper's vehicle)
    seed: int = 1
    out: str = "out"
    realtime: bool = False  # udp only: octo-sim paced like X-Plane
    xplane_version: int = 12
    experiments: list = field(default_factory=lambda: [6])  # [] only flies
    params: dict = field(default_factory=dict)  # {NAME: value} set before the flight
    faults: dict = field(default_factory=dict)  # {FAULTS name: value} for the plant
    build_dir: Optional[str] = None  # None: $OCTO_BUILD, else the repository's build/
    plots: bool = True
    timeout: float = 5.0  # udp: seconds to wait for the vehicle's answers
    wall_limit: Optional[float] = None  # sil: octo-sil is stopped after this many wall seconds
    build: Literal["float", "fixed"] = "float"
    sensors: Optional[list] = None  # names from SENSORS the plant serves (None: the plant's default, all)
    start_time: float = 0.0  # the plant clock at the first frame (s)
    shift_origin: list = field(default_factory=list)  # plant times (s) of an OpenGL origin shift

    def __post_init__(self):
        self.check()

    def check(self):
        """Raises GcsError naming the option that cannot fly."""
        if self.plant not in PLANTS:
            raise GcsError(f"plant {self.plant!r}: must be one of {', '.join(PLANTS)}")
        if self.xplane_version not in (11, 12):
            raise GcsError(f"X-Plane version {self.xplane_version}: must be 11 or 12")
        self.experiments = [check_experiment(int(e)) for e in self.experiments]
        for name, value in self.params.items():
            if not isinstance(value, (int, float)):
                raise GcsError(f"parameter {name}: {value!r} is not a number")
        for name in self.faults:
            if name not in FAULTS:
                raise GcsError(f"fault {name!r} unknown (known: {', '.join(FAULTS)})")
        if self.build not in BUILDS:
            raise GcsError(f"build {self.build!r}: must be one of {', '.join(BUILDS)}")
        if self.sensors is not None:
            self.sensors = sensors_list(self.sensors, "sensors")
        self.start_time = plant_time(self.start_time, "start time")
        self.shift_origin = [plant_time(t, "origin shift time") for t in self.shift_origin]
        if self.plant == "sil" and self.realtime:
            raise GcsError("--in-process runs lockstep only (octo-sil): --realtime needs the UDP mission")

    def to_json(self):
        return dataclasses.asdict(self)

    @classmethod
    def from_json(cls, doc):
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(doc) - known)
        if unknown:
            raise GcsError(f"mission options: unknown {', '.join(unknown)}")
        return cls(**doc)


def sensors_list(value, what="--sensors"):
    """The sensor names of `value` (a list of names, or one comma-separated text), each once, in
    SENSORS' order. Raises GcsError naming `what` and the bad name."""
    names = value.split(",") if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not names:
        raise GcsError(f"{what}: {value!r}: expected a non-empty list from {', '.join(SENSORS)}")
    for n in names:
        if not isinstance(n, str) or n.strip() not in SENSORS:
            raise GcsError(f"{what}: unknown sensor {n!r} (known: {', '.join(SENSORS)})")
    chosen = {n.strip() for n in names}
    return [n for n in SENSORS if n in chosen]


def plant_time(value, what):
    """A plant time in seconds, in [0, PLANT_TIME_MAX_S]; raises GcsError naming `what`."""
    try:
        t = float(value)
    except (TypeError, ValueError):
        raise GcsError(f"{what} {value!r}: not a number of seconds") from None
    if not 0.0 <= t <= PLANT_TIME_MAX_S:
        raise GcsError(f"{what} {value!r}: out of range [0, {PLANT_TIME_MAX_S:g}] s")
    return t


def plant_flags(opts):
    """The plant's command-line flags of MissionOptions `opts` (octo-sim's and octo-sil's alike):
    the sensors served, the start time, the origin shifts and the faults (last)."""
    out = []
    if opts.sensors is not None:
        out += ["--sensors", ",".join(opts.sensors)]
    if opts.start_time:
        out += ["--start-time", repr(float(opts.start_time))]
    for t in opts.shift_origin:
        out += ["--shift-origin", repr(float(t))]
    return out + fault_flags(opts.faults)


def plant_words(opts):
    """What the plant is asked beyond its defaults, for the first line ("" when nothing)."""
    words = []
    if opts.sensors is not None:
        words.append("sensors " + ",".join(opts.sensors))
    if opts.start_time:
        words.append(f"clock from {opts.start_time:g} s")
    if opts.shift_origin:
        words.append("origin shifts at " + ", ".join(f"{t:g}" for t in opts.shift_origin) + " s")
    return "".join(", " + w for w in words)


def firmware_program(opts):
    """The firmware program of the UDP plant: octo-fw, or octo-fw-fixed for the Q16.16 build."""
    return "octo-fw-fixed" if opts.build == "fixed" else "octo-fw"


def sil_program(opts):
    """The in-process program: octo-sil, or octo-sil-fixed for the Q16.16 build."""
    return "octo-sil-fixed" if opts.build == "fixed" else "octo-sil"


def fault_flags(faults):
    """The plant's command-line flags of `faults` ({name: value}), in the names' order."""
    out = []
    for name in sorted(faults):
        flag, integer, _lo, _hi = FAULTS[name]
        x = faults[name]
        out += [flag, str(int(x)) if integer else repr(float(x))]
    return out


# ---------------------------------------------------------------- the command line's words
def experiments_option(text):
    """--experiments: '6', '1,3,4', or 'none' (only fly)."""
    if str(text).strip().lower() in ("none", "0", ""):
        return []
    return parse_experiments(text)


def _name_values(items, option, example):
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            out[name.strip()] = float(value)
        except ValueError:
            raise GcsError(f"{option} {item!r}: expected NAME=VALUE, e.g. {example}") from None
    return out


def param_options(items):
    """--param NAME=VALUE (repeatable) -> {NAME: value}."""
    return _name_values(items, "--param", "ID_INR_TIME=20")


def fault_options(items):
    """--fault NAME=VALUE (repeatable) -> {NAME: value}."""
    out = _name_values(items, "--fault", "drop=0.02")
    for name in out:
        if name not in FAULTS:
            raise GcsError(f"--fault {name}: unknown (known: {', '.join(FAULTS)})")
    return out
