/* cmdline.c - octo-sil's command line into struct sil_config, and --help (see sil.h). */
#include "sil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] = "usage: octo-sil [options]\n"
			    "  octo-fw's app and octo-sim's plant in one process, lockstep, deterministic: the\n"
			    "  X-Plane datagrams pass as bytes through both sides' encoders and decoders, without\n"
			    "  sockets. Same flags, same bytes (LCM logs, parameter file).\n"
			    "\n"
			    "firmware:\n"
			    "  --params FILE            parameter storage (loaded at start, saved atomically)\n"
			    "  --actuation dref|data25  throttles as DREFs (default) or one DATA row 25 datagram\n"
			    "  --lcm-fw URL             octo-fw's log (file://PATH: LCM log in simulated time)\n"
			    "  --log-every N            both logs: every Nth frame (1); events and identification\n"
			    "                           results always\n"
			    "  --log-phases             octo-fw's log: every frame during experiments; outside\n"
			    "                           them none, or every Nth with --log-every N\n"
			    "  --mavlink-listen PORT    serve MAVLink on UDP PORT to watch a run (telemetry rates\n"
			    "  --gcs HOST:PORT          then in wall-clock time; ground station 127.0.0.1:14550)\n"
			    "\n"
			    "plant (octo-sim's flags):\n"
			    "  --vehicle FILE.json  --ideal  --seed N  --rate HZ  --step S  --xplane-version 11|12\n"
			    "  --rows LIST  --drop P  --burst N  --burst-prob P  --delay-frames K  --duplicate P\n"
			    "  --reorder P  --start-time S   (see octo-sim --help; the plant clock starts at S,\n"
			    "                       --duration counts from there)\n"
			    "  --sensors LIST           what the plant serves: imu,rpm,torque,thrust (all)\n"
			    "  --shift-origin T         move the plant's local origin at T (repeatable)\n"
			    "  --fail-rotor J@T[:S]     rotor J (1..8) keeps S (0..1, default 0) of its thrust\n"
			    "                           from plant time T (repeatable)\n"
			    "  --imu-spike P            an IMU axis reads an outlier with probability P per frame\n"
			    "  --imu-spike-gyro G  --imu-spike-accel A   the outliers' sizes (5 rad/s, 50 m/s^2)\n"
			    "  --stuck-rpm J@T          rotor J's ESC speed report freezes from plant time T\n"
			    "                           (repeatable)\n"
			    "  --lcm-sim URL            octo-sim's truth log (OCTO_TRUTH)\n"
			    "\n"
			    "run:\n"
			    "  --duration S             stop after S simulated seconds (0: until the script ends\n"
			    "                           or SIGINT/SIGTERM)\n"
			    "  --script FILE|TEXT       the ground station's steps, one per line or ';':\n"
			    "                           param NAME VALUE, arm, takeoff H, wait hold, experiment N,\n"
			    "                           wait experiment, land, wait disarmed, sleep S.\n"
			    "                           Exit 0 when every step completed; 1 naming the step that\n"
			    "                           failed and the firmware's reason (--mission: the same)\n"
			    "  --quiet                  no firmware console messages on stderr\n"
			    "  --help                   this text\n"
			    "exit status: 0 done, 1 a script step failed or did not complete, 2 bad arguments\n";

/* the flags that take a value and are octo-sil's, not the plant's */
static const char *const own[] = {"--params",  "--actuation", "--lcm-fw",         "--lcm-sim", "--script",
				  "--mission", "--duration",  "--mavlink-listen", "--gcs"};

static bool is_own(const char *flag)
{
	for (size_t k = 0; k < sizeof own / sizeof own[0]; k++)
		if (!strcmp(flag, own[k]))
			return true;
	return false;
}

static double parse_duration(const char *v)
{
	char *e = NULL;
	double d = strtod(v, &e);
	if (!*v || *e || !(d >= 0.0) || d > 1e9) {
		fprintf(stderr, "octo-sil: --duration: expected seconds in [0, 1e9], got '%s'\n", v);
		return -1.0;
	}
	return d;
}

/* One of octo-sil's flags with its value: 0, or the exit status 2 after a message. */
static int take_value(struct sil_config *cfg, const char *f, const char *v)
{
	if (!strcmp(f, "--params"))
		cfg->params = v;
	else if (!strcmp(f, "--lcm-fw"))
		cfg->lcm_fw = v;
	else if (!strcmp(f, "--lcm-sim"))
		cfg->lcm_sim = v;
	else if (!strcmp(f, "--script") || !strcmp(f, "--mission"))
		cfg->script = v;
	else if (!strcmp(f, "--duration")) {
		cfg->duration = parse_duration(v);
		if (cfg->duration < 0.0)
			return 2;
	} else if (!strcmp(f, "--mavlink-listen")) {
		if (udp_parse_port("octo-sil", f, v, &cfg->mav_listen))
			return 2;
	} else if (!strcmp(f, "--gcs")) {
		if (udp_parse_hostport("octo-sil", f, v, &cfg->gcs))
			return 2;
	} else if (!strcmp(f, "--actuation")) {
		if (!strcmp(v, "dref"))
			cfg->act = XP_ACT_DREF;
		else if (!strcmp(v, "data25"))
			cfg->act = XP_ACT_DATA25;
		else {
			fprintf(stderr, "octo-sil: --actuation: '%s' is not dref or data25\n", v);
			return 2;
		}
	}
	return 0;
}

int sil_parse_args(int argc, char **argv, struct sil_config *cfg)
{
	memset(cfg, 0, sizeof *cfg);
	cfg->act = XP_ACT_DREF;
	if (udp_parse_hostport("octo-sil", "--gcs", "127.0.0.1:14550", &cfg->gcs))
		return 2;
	cfg->plant_argv = calloc((size_t)argc + 1, sizeof *cfg->plant_argv);
	if (!cfg->plant_argv)
		return 1;
	cfg->plant_argv[cfg->plant_argc++] = argv[0];
	int rc = -1;
	for (int i = 1; i < argc && rc < 0; i++) {
		const char *f = argv[i];
		if (!strcmp(f, "--help") || !strcmp(f, "-h")) {
			fputs(usage, stdout);
			rc = 0;
		} else if (!strcmp(f, "--quiet")) {
			cfg->quiet = true;
		} else if (!strcmp(f, "--log-phases")) {
			cfg->log_phases = true;
		} else if (!strcmp(f, "--log-every") && i + 1 < argc) {
			/* both logs: the firmware's here, the truth's in the plant */
			if (log_every_parse("octo-sil", argv[i + 1], &cfg->log_every))
				rc = 2;
			cfg->plant_argv[cfg->plant_argc++] = argv[i];
			cfg->plant_argv[cfg->plant_argc++] = argv[++i];
		} else if (!is_own(f)) {
			cfg->plant_argv[cfg->plant_argc++] = argv[i];
		} else if (i + 1 >= argc) {
			fprintf(stderr, "octo-sil: %s needs a value (see --help)\n", f);
			rc = 2;
		} else {
			int e = take_value(cfg, f, argv[++i]);
			if (e)
				rc = e;
		}
	}
	if (rc >= 0) {
		free(cfg->plant_argv);
		cfg->plant_argv = NULL;
	}
	if (!cfg->log_every && !cfg->log_phases)
		cfg->log_every = 1;
	return rc;
}
