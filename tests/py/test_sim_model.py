"""octo-sim's C++ unit tests (build/sim-tests): physics (hover, free fall,
torque-free tumble, RK4 order), Gamma_o geometry, actuator, conventions of the
emitter, byte vectors of its encoder, JSON reader and vehicle keys."""

import subprocess

from conftest import binary


def test_sim_unit_tests_pass():
    r = subprocess.run([binary("sim-tests")], capture_output=True, text=True, timeout=120)
    print(r.stdout)
    assert r.returncode == 0, r.stdout + r.stderr
    assert " 0 failed" in r.stdout
    for name in ("hover_holds_altitude_1mm_10s", "free_fall_matches_half_g_t2",
                 "torque_free_tumble_conserves_momentum_and_energy", "rk4_order_error_ratio_16",
                 "geometry_matches_gamma_o", "data_out_vector_rows_16_17"):
        assert f"ok   {name}" in r.stdout
