"""The identified quantities: their keys in report.json and campaigns, labels, units, and the
firmware parameters that hold each estimate, its sd, the plain estimate and the applied value."""


class Quantity:
    def __init__(self, key, label, unit, est, sd, plain, veh, bit, exp):
        self.key, self.label, self.unit = key, label, unit
        self.est, self.sd, self.plain, self.veh = est, sd, plain, veh
        self.bit, self.exp = bit, exp  # ID_RESULT's bit when accepted; the experiment that finds it


QUANTITIES = (
    Quantity("kf", "k_f", "N", "ID_KF_EST", "ID_KF_SD", "ID_KF_PLAIN", "VEH_KF", 1, 1),
    Quantity("ktau", "k_tau", "N m", "ID_KTAU_EST", "ID_KTAU_SD", "ID_KTAU_PLAIN", "VEH_KTAU", 1, 1),
    Quantity("ixx", "I_x", "kg m^2", "ID_IXX_EST", "ID_IXX_SD", None, "VEH_IXX", 2, 3),
    Quantity("iyy", "I_y", "kg m^2", "ID_IYY_EST", "ID_IYY_SD", None, "VEH_IYY", 4, 4),
    Quantity("izz", "I_z", "kg m^2", "ID_IZZ_EST", "ID_IZZ_SD", None, "VEH_IZZ", 8, 5),
)
BY_KEY = {q.key: q for q in QUANTITIES}
KEYS = tuple(q.key for q in QUANTITIES)
LABELS = {q.key: q.label for q in QUANTITIES}


def quantities_of(experiments):
    """The quantities experiments identify (6 = all; 2 = none)."""
    exps = set(experiments)
    if 6 in exps:
        return list(QUANTITIES)
    return [q for q in QUANTITIES if q.exp in exps]
