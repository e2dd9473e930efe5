"""The identification experiments (MAV_CMD_USER_1 param1) and their planned durations."""

from .base import GcsError, fw_default

EXPERIMENTS = {1: "rotor coefficients", 2: "validation", 3: "Ix", 4: "Iy", 5: "Iz", 6: "full sequence"}


def parse_experiments(text):
    """'6' or '1,3,4' -> [6] / [1, 3, 4] (checked)."""
    out = []
    for part in str(text).replace(" ", ",").split(","):
        if not part:
            continue
        try:
            n = int(part)
        except ValueError:
            raise GcsError(f"experiment {part!r} is not a number (1..6)") from None
        out.append(check_experiment(n))
    if not out:
        raise GcsError("no experiment given")
    return out


def check_experiment(n):
    if n not in EXPERIMENTS:
        raise GcsError(f"experiment {n} unknown: " + ", ".join(f"{k} {v}" for k, v in EXPERIMENTS.items()))
    return n


def planned_sim_seconds(params, experiment):
    """Simulated seconds an experiment should last, from the ID_* parameters (an estimate
    for the time-outs; the firmware may add settling time)."""
    exc = params.get("ID_EXC_TIME", fw_default("ID_EXC_TIME"))
    val = params.get("ID_VAL_TIME", fw_default("ID_VAL_TIME"))
    inr = params.get("ID_INR_TIME", fw_default("ID_INR_TIME"))
    return {1: exc, 2: val, 3: inr, 4: inr, 5: inr, 6: 2 * val + exc + 3 * inr}[experiment]


def planned_total(params, experiments):
    """Simulated seconds of all the experiments."""
    return sum(planned_sim_seconds(params, e) for e in experiments) if experiments else 0.0


def phase_of(text):
    """(k, n, name) of the firmware's phase line "ID k/n: name", else None."""
    head, sep, name = text.partition(": ")
    if not sep or not head.startswith("ID "):
        return None
    k, slash, n = head[3:].partition("/")
    if not slash or not k.isdigit() or not n.isdigit():
        return None
    return int(k), int(n), name
