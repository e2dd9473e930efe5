/*
 * main.c - octo-fw on a POSIX host: the main loop.
 *
 * The loop waits (poll, 2 ms) on the X-Plane socket and the ground (MAVLink)
 * socket; every X-Plane DATA frame is handed to app_on_frame (which actuates
 * once), every ground datagram to the MAVLink endpoint (mav_receive); app_tick
 * and then mav_tick run on every pass.
 * SIGINT and SIGTERM are blocked and taken between passes (sigtimedwait), so
 * no handler and no flag outside struct host are needed.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "host.h"
#include "xp_beacon.h"

/* --xplane auto: X-Plane's address from its first beacon, said aloud. A
 * SIGINT/SIGTERM (blocked, pending) ends the wait. */
static int xp_find(struct host *h, const sigset_t *stop_set)
{
	struct xp_beacon b;
	if (xp_beacon_find(30.0, stop_set, &b))
		return -1;
	host_report("found X-Plane %d.%d.%d (beacon %u.%u) on \"%s\" at %s:%u", (int)(b.version / 10000),
		    (int)(b.version / 100 % 100), (int)(b.version % 100), b.major, b.minor, b.name,
		    inet_ntoa(b.addr.sin_addr), ntohs(b.addr.sin_port));
	h->cfg.xplane = b.addr;
	return 0;
}

static uint64_t now_us(const struct host *h) { return hal_wall_us(&h->hal); }

static void receive_plant(struct host *h)
{
	for (int k = 0; k < 256; k++) {
		int got = xp_client_receive(&h->xp, &h->frame, now_us(h));
		if (got < 0)
			break;
		if (got > 0)
			app_on_frame(&h->app, &h->frame);
	}
}

static void receive_ground(struct host *h)
{
	for (int k = 0; k < 256; k++) {
		uint8_t buf[2048];
		struct sockaddr_in from;
		socklen_t fl = sizeof from;
		ssize_t n = recvfrom(h->mav_fd, buf, sizeof buf, 0, (struct sockaddr *)&from, &fl);
		if (n < 0)
			break;
		/* the ground station is whoever sent the last datagram with an
		 * accepted message (valid checksum, and signature when signing) */
		if (mav_receive(&h->mav, buf, (size_t)n) == 0)
			h->mav_empty++; /* not one valid message in it */
		else if (fl >= sizeof from && from.sin_family == AF_INET)
			h->gcs = from;
	}
}

static int run(struct host *h)
{
	const struct host_config *cfg = &h->cfg;
	sigset_t stop_set;
	sigemptyset(&stop_set);
	sigaddset(&stop_set, SIGINT);
	sigaddset(&stop_set, SIGTERM);
	sigprocmask(SIG_BLOCK, &stop_set, NULL);
	signal(SIGPIPE, SIG_IGN);

	h->mav_fd = -1;
	h->gcs = cfg->gcs;
	host_hal_bind(h);
	param_file_set_path(&h->params, cfg->params_path);
	if (cfg->lcm_url && lcm_log_open(&h->log, cfg->lcm_url))
		return 1;
	lcm_log_thin(&h->log, cfg->log_every, cfg->log_phases);
	if (cfg->xplane_auto && xp_find(h, &stop_set))
		return 1;
	if (xp_client_open(&h->xp, cfg->xp_listen, &cfg->xplane, cfg->act))
		return 1;
	h->mav_fd = udp_open_ground("octo-fw", cfg->mav_listen);
	if (h->mav_fd < 0)
		return 1;
	app_init(&h->app, &h->hal);
	mav_init(&h->mav, &h->app, &h->hal, now_us(h));
	if (h->have_key)
		host_report("MAVLink 2 signing on (key from %s)", cfg->signing_key_path);
	host_report("flying X-Plane at %s:%u (listening on %u, actuation %s), MAVLink on %u -> %s:%u",
		    inet_ntoa(cfg->xplane.sin_addr), ntohs(cfg->xplane.sin_port), cfg->xp_listen,
		    cfg->act == XP_ACT_DREF ? "dref" : "data25", cfg->mav_listen, inet_ntoa(h->gcs.sin_addr),
		    ntohs(h->gcs.sin_port));

	const struct timespec no_wait = {0, 0};
	while (sigtimedwait(&stop_set, NULL, &no_wait) < 0) {
		struct pollfd pf[2] = {{.fd = h->xp.fd, .events = POLLIN}, {.fd = h->mav_fd, .events = POLLIN}};
		int r = poll(pf, 2, 2);
		if (r < 0 && errno != EINTR)
			break;
		if (pf[0].revents & POLLIN)
			receive_plant(h);
		if (pf[1].revents & POLLIN)
			receive_ground(h);
		xp_client_poll(&h->xp, now_us(h));
		app_tick(&h->app);
		mav_tick(&h->mav, now_us(h));
	}
	xp_client_release(&h->xp);
	lcm_log_close(&h->log);
	const struct hal_plant_stats *ls = &h->xp.stats;
	host_report("exit: %u frames, %u datagrams dropped (%u foreign); MAVLink %u messages, %u bad checksum, "
		    "%u rejected by signing, %u datagrams without a valid message",
		    ls->frames, ls->dropped, ls->foreign, h->mav.rx_msgs, h->mav.rx_dropped, h->mav.rx_unsigned,
		    h->mav_empty);
	return 0;
}

int main(int argc, char **argv)
{
	struct host *h = calloc(1, sizeof *h);
	if (!h) {
		fprintf(stderr, "octo-fw: out of memory\n");
		return 1;
	}
	int rc = host_parse_args(argc, argv, &h->cfg);
	if (rc < 0 && h->cfg.signing_key_path) {
		if (signing_key_load(h->cfg.signing_key_path, h->signing_key))
			rc = 2;
		else
			h->have_key = true;
	}
	if (rc < 0)
		rc = run(h);
	free(h);
	return rc;
}
