"""The excitation against the attitude budget (experiment.c, tilt_backoff).

A vehicle of the wide envelope (T/W 35, arms of 0.58 m, three weak rotors the firmware has not
learned yet) tilts beyond 9 degrees under the rotor experiment's null-space dithers: those
dithers cancel their torques only with the rotors' true scales. The excitation halves, says
so, and the whole sequence completes where it used to stop at the 15-degree attitude limit;
what it accepts is judged against the truth and its sd.
"""

import json
import re
import subprocess

from conftest import binary
from ident_helpers import fw_said

VEHICLE = {
    "arm_length": 0.578, "delay": 0.0, "inertia": [0.0746, 0.0808, 0.0745], "kf": 60.79, "ktau": 0.3354,
    "mass": 1.423, "motor_tau": 0.0845, "thrust_curve": 0.063,
    "noise": {"attitude_deg": 0.055, "gyro": 0.026, "position": 0.0062, "thrust": 0.0363, "torque": 0.00124},
    "rotor_scale": [1.0, 0.9, 1.0, 1.0, 0.8, 1.0, 0.85, 1.0],
}
LINE = re.compile(r"^ID (kf|ktau|Ixx|Iyy|Izz) ([-0-9.]+) \+/- ([-0-9.]+) (N m accepted|N accepted|kg m\^2 accepted)")
TRUTH = {"kf": (60.79, 0.01), "ktau": (0.3354, 0.01), "Ixx": (0.0746, 0.02), "Iyy": (0.0808, 0.02),
         "Izz": (0.0745, 0.02)}


def test_a_tilting_excitation_halves_and_the_sequence_completes(tmp_path):
    (tmp_path / "v.json").write_text(json.dumps(VEHICLE))
    script = (f"param VEH_MASS {VEHICLE['mass']}; param VEH_ARM_L {VEHICLE['arm_length']}; param ID_SEED 50022; "
              "arm; takeoff 10; wait hold; experiment 6; wait experiment")
    r = subprocess.run([str(binary("octo-sil")), "--seed", "50022", "--vehicle", str(tmp_path / "v.json"),
                        "--duration", "900", "--script", script], capture_output=True, text=True, timeout=120,
                       check=False)
    said = fw_said(r.stderr)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "ID excitation x0.500: tilt beyond 9 deg" in said, said
    assert "ID done" in said and not any(ln.startswith("ID aborted") for ln in said), said
    assert any(ln.startswith("ID kf ") for ln in said), said
    for ln in said:
        m = LINE.match(ln)
        if m:
            t, tol = TRUTH[m.group(1)]
            v, sd = float(m.group(2)), float(m.group(3))
            assert abs(v - t) <= max(3.0 * sd, tol * t), (ln, t)
