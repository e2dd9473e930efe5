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
}

PLANTS = ("udp", "sil")


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
