"""Contracts kept in one place and checked against their other spellings.

- The log record: firmware/app/log.h's APP_LOG_FIELDS is the list; the LCM type
  firmware/lcm/octo_fw_frame_t.lcm must have the same fields (after utime), in the same
  order, with the same types and array sizes.
- octo-gcs's firmware table (generated from `octo-fw --dump-params`) is the firmware's.
"""
import json
import re
import subprocess
from pathlib import Path

from conftest import binary

ROOT = Path(__file__).resolve().parents[2]


def log_table():
    text = (ROOT / "firmware/app/log.h").read_text()
    body = text[text.index("#define APP_LOG_FIELDS"):text.index("struct app_log_frame {")]
    rows = []
    for m in re.finditer(r"\b(ONE|ARR)\((\w+), (\w+), (\w+)(?:, (\d+))?\)", body):
        kind, _ctype, ltype, name, n = m.groups()
        rows.append((ltype, name, int(n) if kind == "ARR" else None))
    return rows


def lcm_fields():
    text = (ROOT / "firmware/lcm/octo_fw_frame_t.lcm").read_text()
    text = re.sub(r"//[^\n]*", "", text)
    body = text[text.index("{") + 1:text.rindex("}")]
    rows = []
    for m in re.finditer(r"(\w+)\s+(\w+)(?:\[(\d+)\])?\s*;", body):
        ltype, name, n = m.groups()
        rows.append((ltype, name, int(n) if n else None))
    return rows


def test_log_table_is_the_lcm_type():
    table = log_table()
    assert len(table) > 30, table   # the parser found the rows
    fields = lcm_fields()
    assert fields[0] == ("int64_t", "utime", None)
    assert fields[1:] == table


def test_gcs_table_is_the_firmwares():
    from octo_fw_table import MODES, PARAMS
    from octo_gcs.link import MODE_NUMBERS, fw_default
    dump = json.loads(subprocess.run([str(binary("octo-fw")), "--dump-params"], check=True,
                                     capture_output=True, text=True, timeout=30).stdout)
    assert {p["name"]: p["default"] for p in dump["params"]} == \
        {name: p["default"] for name, p in PARAMS.items()}
    assert {v: k for k, v in dump["modes"].items()} == MODES
    assert MODE_NUMBERS["HOLD"] == dump["modes"]["HOLD"]
    assert fw_default("ID_VAL_TIME") == next(p["default"] for p in dump["params"]
                                             if p["name"] == "ID_VAL_TIME")
