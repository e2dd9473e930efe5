/*
 * host.h - the host platform's parts (not seen by app/). One struct host holds
 * all of its state; main() allocates it and fills host->hal with the functions
 * of host_hal.c, whose ctx is the struct host itself.
 *
 *   cmdline.c      options into struct host_config, --help, --dump-params
 *   signing_key.c  the --signing-key file rule (hex key or passphrase)
 *   host_hal.c     the struct hal of the host (clocks, sockets, report)
 *   param_file.c   parameter storage in a text file, replaced atomically
 *   lcm_log.c      the firmware log as LCM messages
 *   xp_client.c    the plant link: X-Plane's UDP protocol
 *   xp_beacon.c    --xplane auto: X-Plane found by its BECN beacon
 *   main.c         the main loop
 */
#ifndef OCTO_HOST_H
#define OCTO_HOST_H

#include <netinet/in.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "app.h"
#include "hal.h"
#include "host_report.h"
#include "mav.h"
#include "xp_client.h"

typedef struct _lcm_t lcm_t;
typedef struct _lcm_eventlog_t lcm_eventlog_t;

/* ---- cmdline.c */
struct host_config {
	struct sockaddr_in xplane; /* where X-Plane receives (found when xplane_auto) */
	bool xplane_auto;          /* --xplane auto: from X-Plane's beacon */
	struct sockaddr_in gcs;    /* ground station until one is heard */
	uint16_t xp_listen, mav_listen;
	const char *params_path, *lcm_url, *signing_key_path;
	enum xp_actuation act;
	unsigned log_every; /* --log-every N (0 with --log-phases alone: none outside) */
	bool log_phases;    /* --log-phases: every frame during experiments */
};
/* Fills *cfg from argv. Returns -1 to run, or the exit status (0 after --help
 * or --dump-params, 1 or 2 after an error, reported on stderr). */
int host_parse_args(int argc, char **argv, struct host_config *cfg);

/* ---- signing_key.c: 0, or -1 with the reason on stderr */
int signing_key_load(const char *path, uint8_t key[32]);

/* ---- param_file.c */
struct param_file {
	char path[4096]; /* empty: no storage */
};
void param_file_set_path(struct param_file *pf, const char *path);
int param_file_store(const struct param_file *pf, const char *text, size_t len);
long param_file_fetch(const struct param_file *pf, char *buf, size_t cap);

/* ---- lcm_log.c: URL as for lcm_create; file://PATH writes an event log
 * stamped with plant time (reproducible). Open returns 0 or -1. */
struct lcm_log {
	lcm_t *lcm;
	lcm_eventlog_t *elog;
	/* frame thinning (--log-every, --log-phases): outside an experiment every
	 * `every`-th frame is written (0: none); during one, every frame when `phases`.
	 * Events and identification results are always written. */
	unsigned every;
	bool phases;
	uint64_t frames_seen; /* frames offered outside the written phases */
};
int lcm_log_open(struct lcm_log *lg, const char *url);
/* thinning as above: every >= 1, or 0 with phases (experiments only) */
void lcm_log_thin(struct lcm_log *lg, unsigned every, bool phases);
/* --log-every's value into *out: 0, or 1 after a message on stderr naming prog */
int log_every_parse(const char *prog, const char *v, unsigned *out);
void lcm_log_close(struct lcm_log *lg);
void lcm_log_frame(struct lcm_log *lg, const struct app_log_frame *f);
void lcm_log_event(struct lcm_log *lg, double t_s, int severity, const char *text);
void lcm_log_id_result(struct lcm_log *lg, double t_s, const struct app_id_result *r);

/* ---- host_hal.c */
struct host {
	struct host_config cfg;
	struct xp_client xp;
	struct hal_sensor_frame frame; /* persistent: absent rows keep their values */
	int mav_fd;
	struct sockaddr_in gcs; /* where the ground link sends */
	bool have_key;
	uint8_t signing_key[32];
	uint32_t mav_empty; /* ground datagrams without one accepted message */
	struct param_file params;
	struct lcm_log log;
	struct hal hal;
	struct app app;
	struct mav mav; /* the app's MAVLink endpoint */
};
/* Sets h->hal to the host's functions with h as their context. */
void host_hal_bind(struct host *h);

/* udp_addr.c: command-line ports and HOST:PORT (0, or -1 with a message naming prog,
 * flag and value) and the non-blocking MAVLink socket on all addresses (fd or -1). */
int udp_parse_port(const char *prog, const char *flag, const char *s, uint16_t *out);
int udp_parse_hostport(const char *prog, const char *flag, const char *s, struct sockaddr_in *out);
int udp_open_ground(const char *prog, uint16_t port);

#endif /* OCTO_HOST_H */
