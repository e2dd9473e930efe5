"""octo-sim's request decoder: a malformed throttle command must not count as a
command (in lockstep it would advance the simulation without the client)."""

import xplane_proto as xp
from test_sim_support import HOVER, SimUnderTest

NAN = float("nan")


def test_nan_throttles_do_not_advance_lockstep(launch, port):
    s = SimUnderTest(launch, port, "--lockstep", "--lockstep-timeout", "5", rows=[1])
    f1 = s.start_lockstep([HOVER] * 8)
    s.link.drain()
    # DATA row 25 with NaN / Inf in every column: dropped and counted, not a command
    s.send(xp.encode_data({25: [NAN] * 4 + [float("inf")] * 4}))
    # DREFs with a NaN value for each engine: likewise
    for i in range(8):
        s.send(xp.encode_dref(f"{xp.THRO_USE}[{i}]", NAN))
    assert s.link.recv_data(0.5) is None, "a NaN command advanced the lockstep"
    f2 = s.step([HOVER] * 8)                 # a real command does
    assert f2[1][2] > f1[1][2]
    c = s.counters()
    assert c["rx_bad_value"] >= 16 and c["lockstep_timeouts"] == 0, c
