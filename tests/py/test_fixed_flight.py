"""The fixed-point firmware flies: build/octo-sil-fixed (octo-fw's app on the Q16.16 core)
flies the mission (take-off, experiment 6, landing) on the paper's vehicle with the plant
clock at 0 and at 10^6 s. It identifies as the float build does: every result accepted,
within 4 of its sds of the truth, and within 4 combined sds of the float build's."""

import pytest

from test_time_uptime import check_identified, check_same, fly


@pytest.mark.parametrize("start", (0.0, 1e6))
def test_fixed_build_flies_and_identifies(tmp_path, start):
    fixed = fly(tmp_path, "octo-sil-fixed", start)
    flt = fly(tmp_path, "octo-sil", start)
    print("fixed", {k: v[:2] for k, v in fixed.results.items()})
    print("float", {k: v[:2] for k, v in flt.results.items()})
    check_identified(fixed)
    check_identified(flt)
    check_same(fixed, flt)
    # the same mission: landed and disarmed at about the same time
    assert abs(fixed.frames[-1].t - flt.frames[-1].t) < 5.0
