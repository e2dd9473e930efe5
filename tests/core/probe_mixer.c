/*
 * probe_mixer - the mixer through stdin/stdout, for the numpy reference tests
 * (tests/py/test_core_reference.py). Not firmware; one request per line:
 *
 *   init L KF KTAU MASK T_MIN T_MAX MODE      set up (MODE 0 clip, 1 priority)
 *   gamma                                     -> {"rank":..,"gamma":[[8]x4],"pinv":[[4]x8],"null":[[n]x8],"alloc":..}
 *   mix F TX TY TZ                            -> {"f":[8],"achieved":[4],"limits":..,"steps":..}
 *
 * Built by tests/core/probe.mk as build/probe-mixer (float) and build/probe-mixer-fixed (Q16.16).
 */
#include "unit_scalar.h"
#include "mixer.h"

#include <stdio.h>
#include <string.h>

static struct mixer mix;
static struct mixer_design des; /* the float32 set-up results (not kept by struct mixer) */

int main(void)
{
	char line[512];
	struct mixer_params p;
	mixer_default_params(&p);
	mixer_init_design(&mix, &p, &des);
	while (fgets(line, sizeof line, stdin)) {
		double a[8];
		unsigned mask;
		int mode;
		if (sscanf(line, "init %lf %lf %lf %u %lf %lf %d", &a[0], &a[1], &a[2], &mask, &a[3], &a[4], &mode) ==
		    7) {
			mixer_default_params(&p);
			p.arm_l_m = sc_from_float((float)a[0]);
			p.k_f_n = sc_from_float((float)a[1]);
			p.k_tau_nm = sc_from_float((float)a[2]);
			p.rotor_mask = (uint8_t)mask;
			p.t_min = sc_from_float((float)a[3]);
			p.t_max = sc_from_float((float)a[4]);
			p.mode = mode ? MIXER_MODE_PRIORITY : MIXER_MODE_CLIP;
			int ok = mixer_init_design(&mix, &p, &des);
			printf("{\"ok\":%d,\"l\":%.9g,\"kf\":%.9g,\"ktau\":%.9g,\"f_lo\":%.9g,\"f_hi\":%.9g}\n", ok,
			       d(p.arm_l_m), d(p.k_f_n), d(p.k_tau_nm), d(mix.f_lo), d(mix.f_hi));
		} else if (strncmp(line, "gamma", 5) == 0) {
			printf("{\"rank\":%d,\"alloc\":%d,\"gamma\":[", mix.rank, mix.alloc_ok);
			for (int i = 0; i < 4; i++) {
				printf("%s[", i ? "," : "");
				for (int j = 0; j < 8; j++)
					printf("%s%.9g", j ? "," : "", (double)des.gamma_f[i][j]);
				printf("]");
			}
			printf("],\"pinv\":[");
			for (int j = 0; j < 8; j++) {
				printf("%s[", j ? "," : "");
				for (int i = 0; i < 4; i++)
					printf("%s%.9g", i ? "," : "", (double)des.pinv_f[j][i]);
				printf("]");
			}
			printf("],\"pinv_scalar\":[");
			for (int j = 0; j < 8; j++) {
				printf("%s[", j ? "," : "");
				for (int i = 0; i < 4; i++)
					printf("%s%.9g", i ? "," : "", d(mix.pinv[j][i]));
				printf("]");
			}
			printf("],\"null\":[");
			for (int j = 0; j < 8; j++) {
				printf("%s[", j ? "," : "");
				for (int k = 0; k < des.n_null; k++)
					printf("%s%.9g", k ? "," : "", (double)des.null_f[j][k]);
				printf("]");
			}
			printf("]}\n");
		} else if (sscanf(line, "mix %lf %lf %lf %lf", &a[0], &a[1], &a[2], &a[3]) == 4) {
			scalar_t dem[4];
			for (int i = 0; i < 4; i++)
				dem[i] = sc_from_float((float)a[i]);
			struct mixer_output o;
			mixer_update(&mix, dem, &o);
			printf("{\"f\":[");
			for (int j = 0; j < 8; j++)
				printf("%s%.9g", j ? "," : "", d(o.f_n[j]));
			printf("],\"demanded\":[");
			for (int i = 0; i < 4; i++)
				printf("%s%.9g", i ? "," : "", d(o.demanded[i]));
			printf("],\"achieved\":[");
			for (int i = 0; i < 4; i++)
				printf("%s%.9g", i ? "," : "", d(o.achieved[i]));
			printf("],\"limits\":%u,\"steps\":%d}\n", (unsigned)o.limits, o.steps);
		} else {
			printf("{\"error\":\"bad request\"}\n");
		}
		fflush(stdout);
	}
	return 0;
}
