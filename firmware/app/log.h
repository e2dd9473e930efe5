/*
 * log.h - the per-frame record of the autopilot's internal state.
 *
 * The app fills one struct app_log_frame per received frame and hands it to
 * hal_log_frame(); the host platform writes it as LCM type octo.fw_frame_t
 * (firmware/lcm/octo_fw_frame_t.lcm, same fields and meaning).
 */
#ifndef OCTO_APP_LOG_H
#define OCTO_APP_LOG_H

#include <stdbool.h>
#include <stdint.h>

struct app_log_frame {
	int64_t seq;
	double t;
	float dt;
	bool stepped, armed, link_ok;
	int8_t mode;
	int32_t valid;
	float q[4], rate_b[3], pos_i[3], vel_i[3];
	float rotor_thrust[8], rotor_torque[8];
	float q_sp[4], z_sp, vz_ff, pos_sp[2];
	float f_dem, tau_dem[3], f_alloc, tau_alloc[3];
	float rotor_f[8], excitation[8], throttle[8];
	int32_t att_flags, alt_flags, mix_flags, thr_clamped;
	int8_t exp_id, exp_phase;
	float exp_progress, est[8], est_sd[8];
	float kf, ktau, inertia[3], mass;
};

#endif /* OCTO_APP_LOG_H */
