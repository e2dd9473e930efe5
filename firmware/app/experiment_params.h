/*
 * experiment_params.h - the identification parameters (ID_*), part of the
 * parameter table: included at the END of params_table.h (X-macro rows,
 * PARAM(NAME, field, default, min, max, unit, description)).
 *
 * Kept beside experiment.c so that its defaults and these stay one edit apart:
 * a row here overrides the fallback default that experiment.c's prm() uses.
 * Append only (the order is the MAVLink index), so settings and results
 * alternate in groups, each opened by redefining PARAM_FLAGS: the settings are
 * locked while an experiment runs (PARAM_LOCKED); the results ("Result
 * (read-only)") are also read-only (PARAM_READONLY) and written by the app
 * when an experiment posts them. A row appended at the end takes the flags of
 * the last group: a new setting opens a settable group of its own.
 */
PARAM(ID_EXC_KIND, id_exc_kind, 1.0f, 0.0f, 2.0f, "",
      "Rotor excitation: 0 uniform (the paper's delta_1), 1 PRBS, 2 multisine")
PARAM(ID_EXC_AMP, id_exc_amp, 0.04f, 0.0f, 0.3f, "", "Rotor excitation amplitude (throttle)")
PARAM(ID_EXC_DIV, id_exc_div, 9.0f, 1.0f, 1000.0f, "", "Frames per excitation value / PRBS bit")
PARAM(ID_EXC_TIME, id_exc_time, 10.0f, 1.0f, 300.0f, "s", "Duration of the rotor-coefficient excitation")
PARAM(ID_EXC_NULL, id_exc_null, 1.0f, 0.0f, 1.0f, "",
      "1: dither through the mixer's null space (no net wrench), 0: rotor 1 only")
PARAM(ID_SEED, id_seed, 1.0f, 0.0f, 1000000.0f, "", "Seed of the excitation signals")
PARAM(ID_MOT_TAU, id_mot_tau, 0.03f, 0.0f, 1.0f, "s", "Motor lag time constant of the lag-aware regressor")
PARAM(ID_DELAY_FR, id_delay_fr, 0.0f, 0.0f, 16.0f, "", "Transport delay of the regressor, frames")
PARAM(ID_INR_AMP, id_inr_amp, 0.8f, 0.0f, 5.0f, "N m", "Torque excitation amplitude of the inertia experiments")
PARAM(ID_INR_TIME, id_inr_time, 10.0f, 1.0f, 3600.0f, "s", "Duration of each inertia experiment")
PARAM(ID_VAL_TIME, id_val_time, 5.0f, 1.0f, 300.0f, "s", "Duration of the validation experiment")
PARAM(ID_RSD_MAX, id_rsd_max, 0.02f, 0.0001f, 1.0f, "",
      "Acceptance: largest relative standard deviation of an estimate")
#undef PARAM_FLAGS
#define PARAM_FLAGS (PARAM_LOCKED | PARAM_READONLY)
PARAM(ID_KF_EST, id_kf_est, 0.0f, -1e9f, 1e9f, "N", "Result (read-only): k_f, lag-aware estimator")
PARAM(ID_KF_SD, id_kf_sd, 0.0f, -1e9f, 1e9f, "N", "Result (read-only): standard deviation of ID_KF_EST")
PARAM(ID_KF_PLAIN, id_kf_plain, 0.0f, -1e9f, 1e9f, "N", "Result (read-only): k_f, the paper's plain estimator (eq. 20)")
PARAM(ID_KTAU_EST, id_ktau_est, 0.0f, -1e9f, 1e9f, "N m", "Result (read-only): k_tau, lag-aware estimator")
PARAM(ID_KTAU_SD, id_ktau_sd, 0.0f, -1e9f, 1e9f, "N m", "Result (read-only): standard deviation of ID_KTAU_EST")
PARAM(ID_KTAU_PLAIN, id_ktau_plain, 0.0f, -1e9f, 1e9f, "N m",
      "Result (read-only): k_tau, the paper's plain estimator (eq. 20)")
PARAM(ID_IXX_EST, id_ixx_est, 0.0f, -1e9f, 1e9f, "kg m^2", "Result (read-only): Ixx")
PARAM(ID_IXX_SD, id_ixx_sd, 0.0f, -1e9f, 1e9f, "kg m^2", "Result (read-only): standard deviation of ID_IXX_EST")
PARAM(ID_IYY_EST, id_iyy_est, 0.0f, -1e9f, 1e9f, "kg m^2", "Result (read-only): Iyy")
PARAM(ID_IYY_SD, id_iyy_sd, 0.0f, -1e9f, 1e9f, "kg m^2", "Result (read-only): standard deviation of ID_IYY_EST")
PARAM(ID_IZZ_EST, id_izz_est, 0.0f, -1e9f, 1e9f, "kg m^2", "Result (read-only): Izz")
PARAM(ID_IZZ_SD, id_izz_sd, 0.0f, -1e9f, 1e9f, "kg m^2", "Result (read-only): standard deviation of ID_IZZ_EST")
PARAM(ID_VAL_NE_PRE, id_val_ne_pre, 0.0f, -1e9f, 1e9f, "",
      "Result (read-only): validation normalised error before identification")
PARAM(ID_VAL_FIT_PRE, id_val_fit_pre, 0.0f, -1e9f, 1e9f, "%",
      "Result (read-only): validation fit before identification")
PARAM(ID_VAL_NE_POST, id_val_ne_post, 0.0f, -1e9f, 1e9f, "",
      "Result (read-only): validation normalised error after identification")
PARAM(ID_VAL_FIT_POST, id_val_fit_post, 0.0f, -1e9f, 1e9f, "%",
      "Result (read-only): validation fit after identification")
PARAM(ID_RESULT, id_result, 0.0f, 0.0f, 255.0f, "", "Result (read-only): bit mask of accepted results (experiment.c)")
PARAM(ID_TAU_CHECK, id_tau_check, 0.0f, -1e9f, 1e9f, "s",
      "Result (read-only): motor lag seen by the rotor experiment (check of ID_MOT_TAU; -1 none)")
/* the rotor model: settings and the priors it refines (locked), then its results */
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
PARAM(ID_CRV_EST, id_crv_est, 1.0f, 0.0f, 1.0f, "",
      "Rotor experiment: 1 estimates the thrust curve MOT_CURVE, 0 takes MOT_CURVE as known")
PARAM(ID_EXC_OFS, id_exc_ofs, 0.03f, 0.0f, 0.2f, "",
      "Rotor experiment: null-space throttle offset moving the rotors' mean throttles apart")
PARAM(MOT_SCALE1, mot_scale1, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 1 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE2, mot_scale2, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 2 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE3, mot_scale3, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 3 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE4, mot_scale4, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 4 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE5, mot_scale5, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 5 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE6, mot_scale6, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 6 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE7, mot_scale7, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 7 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE8, mot_scale8, 1.0f, 0.0f, 4.0f, "",
      "Effectiveness of rotor 8 (1 nominal; found by the rotor experiment; 0: failed, left out)")
PARAM(MOT_SCALE_MIN, mot_scale_min, 0.8f, 0.0f, 1.0f, "",
      "A rotor whose effectiveness is below this is reported degraded")
#undef PARAM_FLAGS
#define PARAM_FLAGS (PARAM_LOCKED | PARAM_READONLY)
PARAM(ID_TAU_SD, id_tau_sd, 0.0f, -1e9f, 1e9f, "s",
      "Result (read-only): standard deviation of the motor lag found (ID_TAU_CHECK)")
PARAM(ID_CRV_SD, id_crv_sd, 0.0f, -1e9f, 1e9f, "", "Result (read-only): standard deviation of the thrust curve found")
PARAM(ID_MOT_NE, id_mot_ne, 0.0f, -1e9f, 1e9f, "",
      "Result (read-only): rotor model residual variance over the measured noise variance")
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
PARAM(ID_ROT_TO, id_rot_to, 0.0f, 0.0f, 1000.0f, "s",
      "Time limit of the rotor experiment (settling included; 0: twice its planned time + 5 s), else it fails")
PARAM(ID_INR_TO, id_inr_to, 0.0f, 0.0f, 1000.0f, "s",
      "Time limit of each inertia experiment (settling included; 0: twice its planned time + 5 s), else it fails")
PARAM(ID_VAL_TO, id_val_to, 0.0f, 0.0f, 1000.0f, "s",
      "Time limit of each validation (settling included; 0: twice its planned time + 5 s), else it fails")
PARAM(ID_GYR_SCL_SD, id_gyr_scl_sd, 0.005f, 0.0f, 0.2f, "",
      "Relative sd of the gyro's scale calibration, carried into the inertia's sd (a scale error s gives I (1 - s): the data cannot see it)")
