/*
 * params_table.h - every parameter of octo-fw, declared once.
 *
 * PARAM(NAME, field, default, min, max, unit, description)
 *   NAME   MAVLink param_id, 16 characters at most, grouped by prefix
 *   field  member of struct app_params (float: every parameter is REAL32)
 *
 * Each row takes the flags (params.h: PARAM_LOCKED, PARAM_READONLY) that
 * PARAM_FLAGS has where the row stands: a group of rows begins by redefining
 * it. The vehicle model, rotor and mixer rows and the identification settings
 * are locked while an experiment runs (it flies and estimates with them); the
 * identification results are read-only (only the app writes them).
 *
 * Walked by the MAVLink parameter handler, the parameter file and
 * `octo-fw --dump-params`. The order is the MAVLink index: append, never
 * reorder, so a ground station's cached table stays valid across versions.
 *
 * The controllers' gains (ATT_*, ALT_*, POS_*) and the guidance rates (NAV_TKO_VEL,
 * NAV_LAND_VEL, NAV_TOUCH_DOWN_S) take their defaults from the core's modules
 * (ATT_CTRL_DEFAULT_*, ALT_CTRL_DEFAULT_*, POS_CTRL_DEFAULT_*, GUID_DEFAULT_*): one
 * source for both.
 *
 * The VEH_* defaults are deliberately off from the truth (k_f 28.0269 N,
 * k_tau 0.3869 N m, I = 0.0628/0.0762/0.1014 kg m^2): identification
 * (the experiment command) is there to find the real values in flight.
 */
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
/*    NAME          field         default  min      max      unit      description */
PARAM(VEH_KF, veh_kf, 20.0f, 1.0f, 500.0f, "N", "Rotor thrust coefficient k_f: f_j = k_f T_j")
PARAM(VEH_KTAU, veh_ktau, 0.3f, 0.001f, 50.0f, "N m", "Rotor torque coefficient k_tau: tau_j = k_tau T_j")
PARAM(VEH_IXX, veh_ixx, 0.05f, 0.001f, 10.0f, "kg m^2", "Moment of inertia about X_B")
PARAM(VEH_IYY, veh_iyy, 0.05f, 0.001f, 10.0f, "kg m^2", "Moment of inertia about Y_B")
PARAM(VEH_IZZ, veh_izz, 0.05f, 0.001f, 10.0f, "kg m^2", "Moment of inertia about Z_B")
PARAM(VEH_MASS, veh_mass, 2.132f, 0.1f, 100.0f, "kg", "Vehicle mass m")
PARAM(VEH_ARM_L, veh_arm_l, 0.35f, 0.05f, 5.0f, "m", "Arm length l (centre to rotor axis)")
PARAM(VEH_GRAV, veh_grav, 9.796f, 9.0f, 10.5f, "m/s^2", "Acceleration of gravity g")
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(ATT_WN_RP, att_wn_rp, ATT_CTRL_DEFAULT_WN_RP_RPS, 1.0f, 40.0f, "rad/s",
      "Roll/pitch attitude loop natural frequency")
PARAM(ATT_WN_YAW, att_wn_yaw, ATT_CTRL_DEFAULT_WN_YAW_RPS, 0.5f, 20.0f, "rad/s", "Yaw attitude loop natural frequency")
PARAM(ATT_ZETA, att_zeta, ATT_CTRL_DEFAULT_ZETA, 0.3f, 2.0f, "", "Attitude loop damping ratio")
PARAM(ATT_KI, att_ki, ATT_CTRL_DEFAULT_KI_RPS, 0.0f, 10.0f, "1/s", "Attitude integral pole")
PARAM(ATT_TILT_MAX, att_tilt_max, POS_CTRL_DEFAULT_TILT_MAX_DEG, 2.0f, 45.0f, "deg",
      "Largest tilt the position loop may ask for")
PARAM(ALT_WN, alt_wn, ALT_CTRL_DEFAULT_WN_RPS, 0.2f, 10.0f, "rad/s", "Height loop natural frequency")
PARAM(ALT_ZETA, alt_zeta, ALT_CTRL_DEFAULT_ZETA, 0.3f, 3.0f, "", "Height loop damping ratio")
PARAM(ALT_KI, alt_ki, ALT_CTRL_DEFAULT_KI_RPS, 0.0f, 10.0f, "1/s", "Height integral pole (removes thrust-scale errors)")
PARAM(POS_VEL_GAIN, pos_vel_gain, POS_CTRL_DEFAULT_VEL_GAIN_RAD_MPS, 0.0f, 2.0f, "rad s/m",
      "Horizontal velocity damping: tilt per m/s")
PARAM(POS_GAIN, pos_gain, POS_CTRL_DEFAULT_POS_GAIN_RPS, 0.0f, 5.0f, "1/s",
      "Horizontal position hold: velocity per metre")
PARAM(NAV_TKO_ALT, nav_tko_alt, 10.0f, 0.5f, 100.0f, "m", "Take-off height when the command gives none")
PARAM(NAV_TKO_VEL, nav_tko_vel, GUID_DEFAULT_TKO_VEL_MPS, 0.1f, 5.0f, "m/s", "Climb rate of take-off")
PARAM(NAV_LAND_VEL, nav_land_vel, GUID_DEFAULT_LAND_VEL_MPS, 0.1f, 3.0f, "m/s", "Descent rate of landing")
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
PARAM(MOT_THR_IDLE, mot_thr_idle, 0.0f, 0.0f, 0.3f, "", "Throttle of every rotor when armed on the ground")
PARAM(MOT_THR_MAX, mot_thr_max, 1.0f, 0.1f, 1.0f, "", "Largest throttle command")
PARAM(MOT_CURVE, mot_curve, 0.0f, THRMAP_CURVE_MIN, THRMAP_CURVE_MAX, "",
      "Thrust curve a: f = k_f ((1 - a) T + a T^2); a < 0: thrust concave in throttle")
PARAM(MIX_MODE, mix_mode, 1.0f, 0.0f, 1.0f, "", "Allocation: 0 pseudo-inverse and clip, 1 box-constrained priority")
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(FS_LINK_TO, fs_link_to, 0.3f, 0.05f, 5.0f, "s", "X-Plane link declared lost after this silence")
PARAM(FS_LAND_AFTER, fs_land_after, 2.0f, 0.1f, 60.0f, "s", "A link loss longer than this lands on recovery")
PARAM(NAV_TOUCH_DOWN_S, nav_touch_down_s, GUID_DEFAULT_TOUCH_DOWN_S, 0.2f, 10.0f, "s",
      "Landing: time on the ground before the motors stop")
/* identification: settings (locked) and results (read-only), kept beside experiment.c */
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
#include "experiment_params.h"
/* the flight envelope (env_hover, env_kf, env_osc, env_limits): limits and tracking settings,
 * and what it learns in flight (HOV_*, KFT_EST/SD/T/MEM: read-only, only the app writes them) */
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(NAV_TKO_TO, nav_tko_to, 60.0f, 1.0f, 600.0f, "s", "Take-off must reach HOLD within this, else it fails and lands")
PARAM(NAV_LAND_TO, nav_land_to, 120.0f, 1.0f, 600.0f, "s",
      "Landing must touch down within this, else it fails (motors stop only on the ground)")
PARAM(NAV_KF_SEED, nav_kf_seed, 0.0f, 0.0f, 1.0f, "",
      "1: a rotor experiment starts from the hover-learned k_f when VEH_KF is > 10 % off")
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_READONLY
PARAM(HOV_THR, hov_thr, 0.0f, -1e9f, 1e9f, "", "Learned (read-only): hover throttle (collective, linearised)")
PARAM(HOV_THR_SD, hov_thr_sd, 0.0f, -1e9f, 1e9f, "", "Learned (read-only): standard deviation of HOV_THR")
PARAM(HOV_KF, hov_kf, 0.0f, -1e9f, 1e9f, "N", "Learned (read-only): k_f = m g / (8 HOV_THR)")
PARAM(HOV_KF_SD, hov_kf_sd, 0.0f, -1e9f, 1e9f, "N", "Learned (read-only): standard deviation of HOV_KF")
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(KFT_DRIFT, kft_drift, 0.02f, 0.001f, 0.5f, "1/min",
      "k_f tracking: largest drift to follow (sizes the memory), fraction per minute")
PARAM(KFT_REFRESH, kft_refresh, 0.02f, 0.0f, 0.5f, "",
      "VEH_KF := KFT_EST in HOLD when they differ by more than this (once identification accepted k_f; 0 off)")
PARAM(KFT_APPLY, kft_apply, 0.0f, 0.0f, 1.0f, "", "Set 1: VEH_KF := KFT_EST now (in HOLD; back to 0 when done)")
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_READONLY
PARAM(KFT_EST, kft_est, 0.0f, -1e9f, 1e9f, "N", "Tracked (read-only): k_f in hover, updated each second")
PARAM(KFT_SD, kft_sd, 0.0f, -1e9f, 1e9f, "N",
      "Tracked (read-only): standard deviation of KFT_EST, with the identified k_f's (absolute once identification accepted k_f)")
PARAM(KFT_T, kft_t, 0.0f, -1e9f, 1e9f, "s", "Tracked (read-only): plant time KFT_EST holds for")
PARAM(KFT_MEM, kft_mem, 0.0f, -1e9f, 1e9f, "s", "Tracked (read-only): memory of the tracker (its averaging time)")
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(NAV_HOLD_TO, nav_hold_to, 30.0f, 0.0f, 600.0f, "s",
      "Hold entry (take-off at its target height: still, hover learned) must reach HOLD within this, else it fails and lands")
/* what identification, hover learning and the k_f tracker measure with (docs/identification.md,
 * "From the IMU") */
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
PARAM(ID_SOURCE, id_source, 0.0f, 0.0f, 4.0f, "",
      "Measurements: 0 auto (thrust rows when served, else the IMU with what ESC telemetry gives), 1 thrust rows, 2 imu, 3 imu_rpm, 4 imu_rpm_torque")
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(KFT_ACC_WALK, kft_acc_walk, 0.001f, 0.0f, 1.0f, "m/s^2/sqrt(s)",
      "k_f tracking from the IMU: accelerometer bias random walk, carried into KFT_SD from the ground calibration")
PARAM(KFT_ACC_NOISE, kft_acc_noise, 0.004f, 0.0f, 1.0f, "m/s^2",
      "Accelerometer white noise per frame on the ground: the ground calibration's error (its mean over the ground frames), carried into HOV_KF_SD")
#undef PARAM_FLAGS
/* the IMU rotor experiment's settings (docs/identification.md, "From the IMU") */
#undef PARAM_FLAGS
#define PARAM_FLAGS PARAM_LOCKED
PARAM(ID_COL_AMP, id_col_amp, 0.03f, 0.0f, 0.2f, "",
      "IMU rotor experiment: amplitude of the collective dither (throttle, on every rotor)")
PARAM(ID_SWP_THR, id_swp_thr, 0.25f, 0.0f, 0.8f, "",
      "Rotor experiment: the throttle sweep's step above hover (0: no sweep), within ID_SWP_DZ")
PARAM(ID_SWP_DZ, id_swp_dz, 0.3f, 0.05f, 1.2f, "m",
      "Rotor experiment: climb each throttle sweep step may cost (thrust rows: 2/3 of it, sinking and back)")
PARAM(ID_IMU_TIME, id_imu_time, 30.0f, 5.0f, 300.0f, "s",
      "IMU rotor experiment: duration of the excitation (the accelerometer's vibration needs more sweeps than thrust rows need)")
PARAM(ID_IZZ_PRI_SD, id_izz_pri_sd, 0.0f, 0.0f, 1.0f, "",
      "Relative sd of VEH_IZZ as a prior (0: none): without ESC torque k_tau is then VEH_IZZ x the ratio k_tau/I_z")
#undef PARAM_FLAGS
#define PARAM_FLAGS (PARAM_LOCKED | PARAM_READONLY)
PARAM(ID_KTIZ, id_ktiz, 0.0f, -1e9f, 1e9f, "1/s^2",
      "Result (read-only): k_tau / I_z from the gyro (identifiable without torque sensing)")
PARAM(ID_KTIZ_SD, id_ktiz_sd, 0.0f, -1e9f, 1e9f, "1/s^2", "Result (read-only): standard deviation of ID_KTIZ")
PARAM(ID_SRC_USED, id_src_used, 0.0f, -1e9f, 1e9f, "",
      "Result (read-only): the source the last identification used (1 thrust, 2 imu, 3 imu_rpm, 4 imu_rpm_torque)")
#undef PARAM_FLAGS
#define PARAM_FLAGS 0
PARAM(NAV_TW_MIN, nav_tw_min, 1.3f, 0.0f, 3.0f, "",
      "Thrust-to-weight below which a take-off lands, saying so, once its hover throttle is learned (0: never)")
#undef PARAM_FLAGS
