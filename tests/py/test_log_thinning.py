"""Log thinning for long runs: `--log-every N` and `--log-phases`.

One octo-sil flight (hover, the rotor experiment, hover) is flown three times with the same
seed: with full logs, with `--log-every 10` and with `--log-phases`. The firmware's frame log
(OCTO_FW_FRAME) and the plant's truth log (OCTO_TRUTH) thin as asked; the events
(OCTO_FW_EVENT) and identification results (OCTO_FW_ID_RESULT) are the same in all three.
octo-sim's and octo-fw's flags are checked too.
"""

import subprocess
from collections import defaultdict

import pytest

from conftest import BUILD, binary

SCRIPT = "arm; takeoff 3; wait hold; experiment 1; wait experiment; sleep 5"


def read_log(path):
    """channel -> list of (timestamp, decoded message or raw bytes)."""
    import lcm
    from octo import fw_event_t, fw_frame_t, fw_id_result_t, truth_t
    types = {"OCTO_FW_FRAME": fw_frame_t, "OCTO_FW_EVENT": fw_event_t, "OCTO_FW_ID_RESULT": fw_id_result_t,
             "OCTO_TRUTH": truth_t}
    out = defaultdict(list)
    for ev in lcm.EventLog(str(path), "r"):
        out[ev.channel].append((ev.timestamp, types[ev.channel].decode(ev.data)))
    return out


def fly(tmp_path, name, *flags):
    fw, truth = tmp_path / f"{name}.fw.lcm", tmp_path / f"{name}.truth.lcm"
    r = subprocess.run([str(binary("octo-sil")), "--seed", "3", "--quiet", "--lcm-fw", f"file://{fw}",
                        "--lcm-sim", f"file://{truth}", *flags, "--script", SCRIPT],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    return read_log(fw), read_log(truth)


@pytest.fixture(scope="module")
def flights(tmp_path_factory):
    d = tmp_path_factory.mktemp("thin")
    return {"full": fly(d, "full"), "every": fly(d, "every", "--log-every", "10"),
            "phases": fly(d, "phases", "--log-phases")}


def same_records(a, b, channel):
    return [(t, m.encode()) for t, m in a[channel]] == [(t, m.encode()) for t, m in b[channel]]


def test_log_every_keeps_every_nth_frame_and_all_events(flights):
    (fw, truth), (fw10, truth10) = flights["full"], flights["every"]
    frames, frames10 = fw["OCTO_FW_FRAME"], fw10["OCTO_FW_FRAME"]
    assert len(frames) > 1000
    # the same flight: every 10th of its frames, from the first
    assert [t for t, _ in frames10] == [t for t, _ in frames][::10]
    assert [m.frame for _, m in truth10["OCTO_TRUTH"]] == \
        [m.frame for _, m in truth["OCTO_TRUTH"] if m.frame % 10 == 0]
    assert len(truth10["OCTO_TRUTH"]) * 10 <= len(truth["OCTO_TRUTH"]) + 10
    assert len(fw["OCTO_FW_EVENT"]) > 3 and len(fw["OCTO_FW_ID_RESULT"]) >= 2
    assert same_records(fw, fw10, "OCTO_FW_EVENT")
    assert same_records(fw, fw10, "OCTO_FW_ID_RESULT")


def test_log_phases_keeps_the_experiment_frames_only(flights):
    (fw, truth), (fwp, truthp) = flights["full"], flights["phases"]
    in_exp = [t for t, m in fw["OCTO_FW_FRAME"] if m.exp_id != 0]
    assert 0 < len(in_exp) < len(fw["OCTO_FW_FRAME"]) - 500
    assert [t for t, _ in fwp["OCTO_FW_FRAME"]] == in_exp
    assert same_records(fw, fwp, "OCTO_FW_EVENT")
    assert same_records(fw, fwp, "OCTO_FW_ID_RESULT")
    # the plant's truth is not thinned by the firmware's phases
    assert len(truthp["OCTO_TRUTH"]) == len(truth["OCTO_TRUTH"])


def test_log_phases_with_every(tmp_path, flights):
    fw = flights["full"][0]
    fwb, _ = fly(tmp_path, "both", "--log-phases", "--log-every", "100")
    outside = [t for t, m in fw["OCTO_FW_FRAME"] if m.exp_id == 0][::100]
    inside = [t for t, m in fw["OCTO_FW_FRAME"] if m.exp_id != 0]
    assert [t for t, _ in fwb["OCTO_FW_FRAME"]] == sorted(outside + inside)


@pytest.mark.parametrize("prog", ["octo-sil", "octo-fw", "octo-sim"])
def test_log_every_flag_checked(prog):
    exe = str(binary(prog))
    for bad in ("0", "x", "-3", ""):
        r = subprocess.run([exe, "--log-every", bad], capture_output=True, text=True, timeout=10)
        assert r.returncode == 2 and "--log-every" in r.stderr, (bad, r.stderr)
    assert "--log-every" in subprocess.run([exe, "--help"], capture_output=True, text=True, timeout=10).stdout
