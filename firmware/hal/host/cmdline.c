/* cmdline.c - octo-fw's options (see --help) and --dump-params. */
#include "host.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "params.h"

static const char usage[] = "usage: octo-fw [options]\n"
			    "  the autopilot as a software-in-the-loop process: flies X-Plane 11/12 (or octo-sim)\n"
			    "  over X-Plane's UDP protocol, talks MAVLink 2 to a ground station\n"
			    "\n"
			    "  --xplane HOST:PORT|auto  where X-Plane receives (127.0.0.1:49000); only datagrams\n"
			    "                           from HOST are accepted. auto: host and port from the first\n"
			    "                           X-Plane beacon (BECN on 239.255.1.1:49707; waits up to 30 s)\n"
			    "  --xp-listen PORT         X-Plane Data Output target port (49005)\n"
			    "  --mavlink-listen PORT    MAVLink UDP port (14580)\n"
			    "  --gcs HOST:PORT          ground station (127.0.0.1:14550); also learned from the\n"
			    "                           source of incoming MAVLink packets\n"
			    "  --params FILE            parameter storage (loaded at start, saved atomically)\n"
			    "  --lcm URL                LCM log: file://PATH (event log in plant time) or an LCM URL\n"
			    "  --log-every N            log every Nth frame (1); events and identification\n"
			    "                           results always\n"
			    "  --log-phases             log every frame during experiments; outside them none,\n"
			    "                           or every Nth with --log-every N\n"
			    "  --actuation dref|data25  throttles as 8 DREFs ENGN_thro_use[i] + override_throttles\n"
			    "                           (default) or one DATA row 25 datagram\n"
			    "  --signing-key FILE       MAVLink 2 signing: unsigned input rejected, output signed.\n"
			    "                           FILE (surrounding white space stripped) holds 64 hex digits\n"
			    "                           (the key) or a passphrase (key = its sha256): the rule of\n"
			    "                           octo-gcs --signing-key and MAVProxy, so one file serves both\n"
			    "  --dump-params            print the parameter table as JSON and exit\n"
			    "  --help                   this text\n";

static void json_str(const char *s)
{
	putchar('"');
	for (; *s; s++) {
		if (*s == '"' || *s == '\\')
			printf("\\%c", *s);
		else if ((unsigned char)*s < 32)
			printf("\\u%04x", *s);
		else
			putchar(*s);
	}
	putchar('"');
}

static void dump_params(void)
{
	printf("{\"params\": [\n");
	for (size_t i = 0; i < param_count; i++) {
		const struct param_def *d = &param_defs[i];
		printf("  {\"index\": %zu, \"name\": ", i);
		json_str(d->name);
		char def[32], min[32], max[32];
		params_fmt_float(def, sizeof def, d->def);
		params_fmt_float(min, sizeof min, d->min);
		params_fmt_float(max, sizeof max, d->max);
		printf(", \"type\": \"REAL32\", \"default\": %s, \"min\": %s, \"max\": %s, \"unit\": ", def, min, max);
		json_str(d->unit);
		printf(", \"description\": ");
		json_str(d->desc);
		printf(", \"locked\": %s, \"readonly\": %s}%s\n", d->flags & PARAM_LOCKED ? "true" : "false",
		       d->flags & PARAM_READONLY ? "true" : "false", i + 1 < param_count ? "," : "");
	}
	printf("], \"modes\": {");
	for (int m = APP_DISARMED; m <= APP_LAND; m++)
		printf("%s\"%s\": %d", m ? ", " : "", app_mode_name((enum app_mode)m), m);
	printf("}}\n");
}

int host_parse_args(int argc, char **argv, struct host_config *cfg)
{
	memset(cfg, 0, sizeof *cfg);
	cfg->xp_listen = 49005;
	cfg->mav_listen = 14580;
	cfg->act = XP_ACT_DREF;
	if (udp_parse_hostport("octo-fw", "--xplane", "127.0.0.1:49000", &cfg->xplane) ||
	    udp_parse_hostport("octo-fw", "--gcs", "127.0.0.1:14550", &cfg->gcs))
		return 1;

	for (int i = 1; i < argc; i++) {
		const char *f = argv[i];
		if (!strcmp(f, "--help") || !strcmp(f, "-h")) {
			fputs(usage, stdout);
			return 0;
		}
		if (!strcmp(f, "--dump-params")) {
			dump_params();
			return 0;
		}
		if (!strcmp(f, "--log-phases")) {
			cfg->log_phases = true;
			continue;
		}
		static const char *const with_value[] = {"--xplane",      "--xp-listen", "--mavlink-listen",
							 "--gcs",         "--params",    "--lcm",
							 "--signing-key", "--actuation", "--log-every"};
		bool known = false;
		for (size_t k = 0; k < sizeof with_value / sizeof with_value[0]; k++)
			known = known || !strcmp(f, with_value[k]);
		if (!known) {
			fprintf(stderr, "octo-fw: unknown option '%s' (see --help)\n", f);
			return 2;
		}
		if (i + 1 >= argc) {
			fprintf(stderr, "octo-fw: %s needs a value (see --help)\n", f);
			return 2;
		}
		const char *v = argv[++i];
		int bad = 0;
		if (!strcmp(f, "--xplane") && !strcmp(v, "auto")) {
			cfg->xplane_auto = true;
		} else if (!strcmp(f, "--xplane")) {
			bad = udp_parse_hostport("octo-fw", f, v, &cfg->xplane);
			cfg->xplane_auto = false;
		} else if (!strcmp(f, "--gcs"))
			bad = udp_parse_hostport("octo-fw", f, v, &cfg->gcs);
		else if (!strcmp(f, "--xp-listen"))
			bad = udp_parse_port("octo-fw", f, v, &cfg->xp_listen);
		else if (!strcmp(f, "--mavlink-listen"))
			bad = udp_parse_port("octo-fw", f, v, &cfg->mav_listen);
		else if (!strcmp(f, "--params"))
			cfg->params_path = v;
		else if (!strcmp(f, "--lcm"))
			cfg->lcm_url = v;
		else if (!strcmp(f, "--signing-key"))
			cfg->signing_key_path = v;
		else if (!strcmp(f, "--log-every"))
			bad = log_every_parse("octo-fw", v, &cfg->log_every);
		else if (!strcmp(f, "--actuation")) {
			if (!strcmp(v, "dref"))
				cfg->act = XP_ACT_DREF;
			else if (!strcmp(v, "data25"))
				cfg->act = XP_ACT_DATA25;
			else {
				fprintf(stderr, "octo-fw: --actuation: '%s' is not dref or data25\n", v);
				bad = 1;
			}
		}
		if (bad)
			return 2;
	}
	if (!cfg->log_every && !cfg->log_phases)
		cfg->log_every = 1;
	return -1;
}
