"""The excitation against the attitude budget and the hover throttle (experiment.c,
tilt_backoff and dither_fit).

A vehicle of the wide envelope (arms of 0.58 m, three weak rotors the firmware has not learned
yet, k_f 61 N):
- at 4.5 kg (thrust-to-weight 11) it tilts beyond 9 degrees under the rotor experiment's
  null-space dithers, which cancel their torques only with the rotors' true scales: the
  excitation halves, says so, and the whole sequence completes where it used to stop at the
  15-degree attitude limit;
- at 1.423 kg (thrust-to-weight 35, hover throttle 0.03) the dithers (0.07 of throttle) would
  take rotors below zero: clipped there, they cancel nothing and the vehicle, its height loop
  without authority below the rotors' zero, climbed past the height limit. Their gain is fitted
  to the hover throttle, said, and the sequence completes.
What either accepts is judged against the truth and its sd.
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


def fly(tmp_path, mass):
    veh = dict(VEHICLE, mass=mass)
    (tmp_path / "v.json").write_text(json.dumps(veh))
    script = (f"param VEH_MASS {mass}; param VEH_ARM_L {veh['arm_length']}; param ID_SEED 50022; "
              "arm; takeoff 10; wait hold; experiment 6; wait experiment")
    r = subprocess.run([str(binary("octo-sil")), "--seed", "50022", "--vehicle", str(tmp_path / "v.json"),
                        "--duration", "900", "--script", script], capture_output=True, text=True, timeout=120,
                       check=False)
    said = fw_said(r.stderr)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "ID done" in said and not any(ln.startswith("ID aborted") for ln in said), said
    assert any(ln.startswith("ID kf ") for ln in said), said
    for ln in said:
        m = LINE.match(ln)
        if m:
            t, tol = TRUTH[m.group(1)]
            v, sd = float(m.group(2)), float(m.group(3))
            assert abs(v - t) <= max(3.0 * sd, tol * t), (ln, t)
    return said


def test_a_tilting_excitation_halves_and_the_sequence_completes(tmp_path):
    said = fly(tmp_path, 4.5)
    assert "ID excitation x0.500: tilt beyond 9 deg" in said, said


def test_dithers_fitted_to_a_low_hover_throttle_and_the_sequence_completes(tmp_path):
    said = fly(tmp_path, 1.423)
    fit = [ln for ln in said if re.match(r"^ID excitation x0\.\d+: hover throttle 0\.03\d$", ln)]
    assert len(fit) == 1, said
    # 0.8 of the hover throttle over the dithers' swing (ID_EXC_AMP 0.04 + ID_EXC_OFS 0.03)
    g, u = (float(x) for x in re.findall(r"0\.\d+", fit[0]))
    assert abs(g - 0.8 * u / 0.07) < 0.02, fit
