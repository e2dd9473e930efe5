"""Faults survived with identification running: frame loss (20 % random; 0.5 s
bursts), duplicated, reordered, delayed frames (each alone, and together). The height holds within +/-0.5 m from the
hover through the experiment, and rotor identification (experiment 1 over MAVLink USER_1
param1=1) is either within its accuracy (k_f within 0.3 % of truth) or aborted with a clear
reason; under a burst storm it is refused, with the reason (a link that lost frames in the
last 10 s). The plain hovers under the same faults are in test_fw_flight.py."""

import json
import re
import time

import pytest

from ident_helpers import MAV_CMD_USER_1, PAPER, IdentFlight, mavlink

# In lockstep, octo-sim does not wait for an answer to a frame its fault injector withheld (lost,
# or held back to be reordered or delayed): it advances holding the last throttles, which the
# rotor model follows exactly; every delivered frame is waited for with the default 0.5 s
# --lockstep-timeout, so a merely late answer is never taken for a later frame. An undeclared
# --delay-frames 2 biases k_f low (1-1.5 %); the rotor experiment sees it in its lag check and
# rejects k_f and k_tau ("ID kf ... rejected: motor lag off"), the vehicle model unchanged.
# Duplicates, and a delay declared in ID_DELAY_FR, are exact (28.03 +/- 0.01 N).
FAULTS = {
    # (octo-sim fault options, octo-fw parameters)
    "drop20": (["--drop", "0.2"], {}),
    # 45 frames = 0.5 s at 90 Hz, seeded so that bursts hit the hover and the excitation; the
    # firmware's own link timeout (FS_LINK_TO 0.3 s) judges the gap in plant time
    "burst0.5s": (["--burst", "45", "--burst-prob", "0.01"], {"FS_LINK_TO": 0.3}),
    "duplicate": (["--duplicate", "0.1"], {}),
    "reorder": (["--reorder", "0.1"], {}),
    "delay2_declared": (["--delay-frames", "2"], {"ID_DELAY_FR": 2}),
    "delay2_undeclared": (["--delay-frames", "2"], {}),
    "dup_reorder_delay": (["--duplicate", "0.1", "--reorder", "0.1", "--delay-frames", "2"], {}),
}
CASES = list(FAULTS)


@pytest.mark.parametrize("fault", CASES)
def test_identification_under_frame_faults(launch, port, tmp_path, fault):
    args, params = FAULTS[fault]
    fl = IdentFlight(launch, port, tmp_path, seed=4, duration=600, params=params, extra_sim_args=args)
    fl.takeoff()
    refused = None
    if fault.startswith("burst"):
        # a burst storm loses frames every 1.6 s on average: the experiment is refused, saying
        # why (frames lost within the last 10 s: the plant holds the throttles through a gap,
        # and a sweep step held climbs metres)
        # (or, when a burst has just tilted it, it first waits for the hover, then for the link)
        n0 = len(fl.rig.texts)
        r, texts = fl.rig.cmd(MAV_CMD_USER_1, 1)
        if r == mavlink.MAV_RESULT_IN_PROGRESS:
            fl.wait_text(lambda t: t.startswith(("Experiment 1 not started", "ID 1/1")), 60)
            texts = fl.rig.texts[n0:]
        said = "".join(texts)  # a line beyond STATUSTEXT's 50 characters comes in chunks
        # the link's gaps, or the attitude a gap left oscillating, or the tilt it left
        refused = re.findall(r"Experiment 1 (?:refused|not started): \S.*", said)
        assert r in (mavlink.MAV_RESULT_TEMPORARILY_REJECTED, mavlink.MAV_RESULT_IN_PROGRESS) and refused, \
            (r, texts)
    else:
        texts = fl.experiment(1, timeout=60)
    done = "ID done" in texts
    aborted = [t for t in texts if t.startswith("ID aborted")]
    # rejected at the end: the k_f line says why (and the vehicle model stays as it was)
    aborted += [t for t in texts if t.startswith("ID kf ") and " rejected: " in t]
    done = done and not aborted
    kf = fl.param("ID_KF_EST") if done else None
    veh_kf = fl.param("VEH_KF")
    time.sleep(0.5)                         # hover on (lockstep: many simulated seconds)
    fl.finish()

    # the sim's counters: the fault really happened
    err = fl.rig.sim.stderr_path.read_text()
    c = json.loads(re.search(r"counters (\{.*\})", err).group(1))
    if fault.startswith(("drop", "burst")):
        assert c["fault_dropped"] >= (45 if fault.startswith("burst") else 100), c
    if "dup" in fault:
        assert c["fault_duplicated"] > 0, c
    if "reorder" in fault:
        assert c["fault_reordered"] > 0, c

    # height: from 2 s into the hover to the end of the experiment
    events = fl.events
    t_hold = min(e.utime * 1e-6 for e in events if e.text == "Mode HOLD")
    # to 3 s after the experiment's last line (done, aborted or rejected): identification under
    # faults. The hover after it under the same faults is not judged here: a burst storm
    # (0.5 s blackouts every 1.6 s on average) held for minutes can tip the vehicle, whose
    # held corrections act blind for half a second each time (an open finding,
    # docs/reliability.md)
    t_exp_end = max(e.utime * 1e-6 for e in events
                    if e.text == "ID done" or e.text.startswith(("ID aborted", "ID kf ", "Experiment 1 refused", "Experiment 1 not started")))
    t_end = min(fl.truth[-1].t, t_exp_end + 3.0)
    z0 = fl.truth[0].pos_i[2]
    window = [s for s in fl.truth if t_hold + 2.0 <= s.t <= t_end]
    dz = [s.pos_i[2] - z0 - 5.0 for s in window]
    print(f"{fault}: hover {window[0].t:.1f}..{window[-1].t:.1f} s, |dz| <= {max(map(abs, dz)):.3f} m, "
          f"k_f {kf} (truth {PAPER['kf']}), VEH_KF {veh_kf}, aborted {aborted}, sim {c}\n{texts}")
    assert window[-1].t - window[0].t > 5.0
    # a lockstep timeout (octo-sim advancing without a late answer) is the host's load, not the
    # firmware's: said beside the height so that a failure names it
    assert max(abs(d) for d in dz) <= 0.5, (f"height error up to {max(dz, key=abs):+.3f} m "
                                            f"(lockstep timeouts {c['lockstep_timeouts']})")
    if done and fault.startswith("drop"):
        # under 20 % loss every pattern follows a lost frame: each rise cut to 1 g above the
        # weight, said (docs/identification.md)
        assert re.search(r"ID sweep: (\d+)/\1 rises cut to 1\.0 g, frames lost", "\n".join(texts)), texts
    if done:
        assert abs(kf / PAPER["kf"] - 1) <= 3e-3, f"k_f {kf} vs {PAPER['kf']}"
        assert abs(veh_kf / PAPER["kf"] - 1) <= 3e-3
    else:
        # aborted or refused: a reason a user can act on, and the vehicle model left as it was
        assert refused or (aborted and len(aborted[0]) > len("ID aborted: ")), texts
        assert veh_kf == 20.0
