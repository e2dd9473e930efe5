"""Parameter files in MAVProxy's ``NAME VALUE`` format.

Reading follows MAVProxy's loader (``#`` starts a comment anywhere on a line, a comma
counts as white space, one name and one number per line); unlike it, a damaged line is
reported with its line number instead of being printed and skipped silently. Writing
follows MAVProxy's ``param save`` (sorted, ``%-16.16s %f``) and is atomic: the file is
either the complete old or the complete new version.
"""

import math
import re

from .atomicfile import atomic_write

NAME_RE = re.compile(r"^[A-Za-z0-9_]{1,16}$")


class ParamFileError(ValueError):
    """A damaged parameter file; ``problems`` lists (line number, message)."""

    def __init__(self, path, problems):
        self.path = path
        self.problems = problems
        lines = "; ".join(f"line {n}: {m}" for n, m in problems)
        super().__init__(f"{path}: {lines}")


def parse(text, path="<text>"):
    """Parse file contents into an ordered dict {NAME: float}.

    Raises ParamFileError listing every damaged line (bad name, bad number, NaN/Inf,
    wrong field count, a name given twice)."""
    params, problems = {}, []
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].replace(",", " ").strip()
        if not line:
            continue
        fields = line.split()
        if len(fields) != 2:
            problems.append((n, f"expected 'NAME VALUE', got {raw.strip()!r}"))
            continue
        name, value = fields
        if not NAME_RE.match(name):
            problems.append((n, f"bad parameter name {name!r} (1-16 of A-Z, 0-9, _)"))
            continue
        try:
            v = int(value[2:], 16) if value.lower().startswith("0x") else float(value)
        except ValueError:
            problems.append((n, f"{name}: {value!r} is not a number"))
            continue
        if not math.isfinite(v):
            problems.append((n, f"{name}: {value} is not finite"))
            continue
        if name in params:
            problems.append((n, f"{name} given twice"))
            continue
        params[name] = float(v)
    if problems:
        raise ParamFileError(path, problems)
    return params


def load(path):
    with open(path, "r", encoding="utf-8", errors="replace") as f:
        return parse(f.read(), str(path))


def format_params(params):
    """MAVProxy's layout: sorted names, 16-character name column, %f values."""
    return "".join("%-16.16s %f\n" % (k, params[k]) for k in sorted(params))


def save(path, params):
    """Write atomically (see atomicfile): the complete old or the complete new file."""
    atomic_write(path, format_params(params))
