/*
 * main.c - octo-fw on a POSIX host: command line, sockets, the main loop, and
 * the hal.h functions that need them (time, actuation, MAVLink bytes, report).
 *
 * The loop waits (poll, 2 ms) on the X-Plane socket and the MAVLink socket;
 * every X-Plane DATA frame is handed to app_on_frame (which actuates once),
 * every MAVLink datagram to app_on_mavlink; app_tick runs on every pass.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <octo/mavlink.h>

#include "app.h"
#include "hal.h"
#include "host.h"
#include "params.h"
#include "xp_beacon.h"
#include "xp_client.h"

static struct xp_client xp;
static struct app app;
static struct hal_sensor_frame frame;   /* persistent: absent rows keep their values */
static int mav_fd = -1;
static struct sockaddr_in gcs;
static volatile sig_atomic_t stop;
static bool have_key;
static uint8_t signing_key[32];
static uint32_t mav_empty;   /* MAVLink datagrams without one accepted message */

/* ---------------------------------------------------------------- hal.h */

uint64_t hal_wall_us(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

void hal_actuate(const float thr[HAL_ROTORS])
{
	xp_client_actuate(&xp, thr, hal_wall_us());
}

void hal_link_stats(struct hal_link_stats *out)
{
	*out = xp.stats;
}

void hal_mav_send(const uint8_t *buf, size_t len)
{
	if (mav_fd >= 0)
		(void)sendto(mav_fd, buf, len, 0, (const struct sockaddr *)&gcs, sizeof gcs);
}

bool hal_signing_key(uint8_t key[32])
{
	if (have_key)
		memcpy(key, signing_key, sizeof signing_key);
	return have_key;
}

uint64_t hal_unix_us(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_REALTIME, &ts);
	return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static int hexval(int c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	if (c >= 'a' && c <= 'f')
		return c - 'a' + 10;
	if (c >= 'A' && c <= 'F')
		return c - 'A' + 10;
	return -1;
}

/* --signing-key FILE, the rule of octo-gcs (and MAVProxy's passphrase): the
 * file's text with surrounding white space stripped (as Python's bytes.strip:
 * space, \t \n \v \f \r); exactly 64 hex digits are the key itself, anything
 * else is a passphrase and the key is its sha256. An empty file is an error. */
static bool key_space(uint8_t c)
{
	return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

static int load_signing_key(const char *path)
{
	FILE *f = fopen(path, "rb");
	if (!f) {
		fprintf(stderr, "octo-fw: --signing-key: cannot open %s: %s\n", path, strerror(errno));
		return -1;
	}
	static uint8_t buf[65536];
	size_t n = fread(buf, 1, sizeof buf, f);
	bool more = fgetc(f) != EOF;
	fclose(f);
	if (more) {
		fprintf(stderr, "octo-fw: --signing-key: %s is longer than %zu bytes\n", path, sizeof buf);
		return -1;
	}
	size_t a = 0, b = n;
	while (a < b && key_space(buf[a]))
		a++;
	while (b > a && key_space(buf[b - 1]))
		b--;
	if (a == b) {
		fprintf(stderr, "octo-fw: --signing-key: %s is empty\n", path);
		return -1;
	}
	bool hex = b - a == 64;
	for (size_t i = a; i < b && hex; i++)
		hex = hexval(buf[i]) >= 0;
	if (hex) {
		for (size_t i = 0; i < 32; i++)
			signing_key[i] = (uint8_t)(hexval(buf[a + 2 * i]) << 4 | hexval(buf[a + 2 * i + 1]));
	} else {
		/* sha256 with MAVLink's own implementation: after final_48 the whole
		 * digest is in the counters (big-endian words) */
		mavlink_sha256_ctx ctx;
		uint8_t first6[6];
		mavlink_sha256_init(&ctx);
		mavlink_sha256_update(&ctx, buf + a, (uint32_t)(b - a));
		mavlink_sha256_final_48(&ctx, first6);
		for (int w = 0; w < 8; w++)
			for (int k = 0; k < 4; k++)
				signing_key[4 * w + k] = (uint8_t)(ctx.counter[w] >> (24 - 8 * k));
	}
	have_key = true;
	return 0;
}

void hal_report(const char *fmt, ...)
{
	char text[256];
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(text, sizeof text, fmt, ap);
	va_end(ap);
	fprintf(stderr, "octo-fw: %s\n", text);
}

/* ---------------------------------------------------------------- command line */

static const char usage[] =
	"usage: octo-fw [options]\n"
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
	"  --actuation dref|data25  throttles as 8 DREFs ENGN_thro_use[i] + override_throttles\n"
	"                           (default) or one DATA row 25 datagram\n"
	"  --signing-key FILE       MAVLink 2 signing: unsigned input rejected, output signed.\n"
	"                           FILE (surrounding white space stripped) holds 64 hex digits\n"
	"                           (the key) or a passphrase (key = its sha256): the rule of\n"
	"                           octo-gcs --signing-key and MAVProxy, so one file serves both\n"
	"  --dump-params            print the parameter table as JSON and exit\n"
	"  --help                   this text\n";

static int parse_port(const char *flag, const char *s, uint16_t *out)
{
	char *e = NULL;
	long v = strtol(s, &e, 10);
	if (!*s || *e || v < 1 || v > 65535) {
		fprintf(stderr, "octo-fw: %s: '%s' is not a port (1..65535)\n", flag, s);
		return -1;
	}
	*out = (uint16_t)v;
	return 0;
}

static int parse_hostport(const char *flag, const char *s, struct sockaddr_in *out)
{
	char host[256];
	const char *colon = strrchr(s, ':');
	if (!colon || colon == s || (size_t)(colon - s) >= sizeof host) {
		fprintf(stderr, "octo-fw: %s: '%s' is not HOST:PORT\n", flag, s);
		return -1;
	}
	memcpy(host, s, (size_t)(colon - s));
	host[colon - s] = 0;
	uint16_t port;
	if (parse_port(flag, colon + 1, &port))
		return -1;
	struct addrinfo hints, *res = NULL;
	memset(&hints, 0, sizeof hints);
	hints.ai_family = AF_INET;
	hints.ai_socktype = SOCK_DGRAM;
	if (getaddrinfo(host, NULL, &hints, &res) || !res) {
		fprintf(stderr, "octo-fw: %s: unknown host '%s'\n", flag, host);
		return -1;
	}
	memcpy(out, res->ai_addr, sizeof *out);
	freeaddrinfo(res);
	out->sin_port = htons(port);
	return 0;
}

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
		printf(", \"type\": \"REAL32\", \"default\": %s, \"min\": %s, \"max\": %s, \"unit\": ", def,
		       min, max);
		json_str(d->unit);
		printf(", \"description\": ");
		json_str(d->desc);
		printf("}%s\n", i + 1 < param_count ? "," : "");
	}
	printf("]}\n");
}

static void on_signal(int sig)
{
	(void)sig;
	stop = 1;
}

static int open_mavlink(uint16_t port)
{
	int fd = socket(AF_INET, SOCK_DGRAM, 0);
	if (fd < 0) {
		perror("octo-fw: MAVLink socket");
		return -1;
	}
	struct sockaddr_in a;
	memset(&a, 0, sizeof a);
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_ANY);
	a.sin_port = htons(port);
	if (bind(fd, (struct sockaddr *)&a, sizeof a) < 0) {
		fprintf(stderr, "octo-fw: cannot bind MAVLink port %u: %s\n", port, strerror(errno));
		close(fd);
		return -1;
	}
	(void)fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	return fd;
}

/* --xplane auto: X-Plane's address from its first beacon, said aloud. */
static int xp_find(struct sockaddr_in *xplane)
{
	struct xp_beacon b;
	if (xp_beacon_find(30.0, &stop, &b))
		return -1;
	hal_report("found X-Plane %d.%d.%d (beacon %u.%u) on \"%s\" at %s:%u", (int)(b.version / 10000),
		   (int)(b.version / 100 % 100), (int)(b.version % 100), b.major, b.minor, b.name,
		   inet_ntoa(b.addr.sin_addr), ntohs(b.addr.sin_port));
	*xplane = b.addr;
	return 0;
}

int main(int argc, char **argv)
{
	struct sockaddr_in xplane;
	uint16_t xp_listen = 49005, mav_listen = 14580;
	const char *params_path = NULL, *lcm_url = NULL, *signing_key_path = NULL;
	enum xp_actuation act = XP_ACT_DREF;
	bool xplane_auto = false;
	if (parse_hostport("--xplane", "127.0.0.1:49000", &xplane) ||
	    parse_hostport("--gcs", "127.0.0.1:14550", &gcs))
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
		static const char *const with_value[] = {"--xplane", "--xp-listen", "--mavlink-listen", "--gcs",
							  "--params", "--lcm", "--signing-key", "--actuation"};
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
		if (!strcmp(f, "--xplane") && !strcmp(v, "auto"))
			xplane_auto = true;
		else if (!strcmp(f, "--xplane")) {
			bad = parse_hostport(f, v, &xplane);
			xplane_auto = false;
		}
		else if (!strcmp(f, "--gcs"))
			bad = parse_hostport(f, v, &gcs);
		else if (!strcmp(f, "--xp-listen"))
			bad = parse_port(f, v, &xp_listen);
		else if (!strcmp(f, "--mavlink-listen"))
			bad = parse_port(f, v, &mav_listen);
		else if (!strcmp(f, "--params"))
			params_path = v;
		else if (!strcmp(f, "--lcm"))
			lcm_url = v;
		else if (!strcmp(f, "--signing-key"))
			signing_key_path = v;
		else if (!strcmp(f, "--actuation")) {
			if (!strcmp(v, "dref"))
				act = XP_ACT_DREF;
			else if (!strcmp(v, "data25"))
				act = XP_ACT_DATA25;
			else {
				fprintf(stderr, "octo-fw: --actuation: '%s' is not dref or data25\n", v);
				bad = 1;
			}
		}
		if (bad)
			return 2;
	}
	if (signing_key_path && load_signing_key(signing_key_path))
		return 2;

	signal(SIGPIPE, SIG_IGN);
	struct sigaction sa;
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);

	param_file_set_path(params_path);
	if (lcm_url && lcm_log_open(lcm_url))
		return 1;
	if (xplane_auto && xp_find(&xplane))
		return 1;
	if (xp_client_open(&xp, xp_listen, &xplane, act))
		return 1;
	mav_fd = open_mavlink(mav_listen);
	if (mav_fd < 0)
		return 1;
	app_init(&app);
	if (have_key)
		hal_report("MAVLink 2 signing on (key from %s)", signing_key_path);
	hal_report("flying X-Plane at %s:%u (listening on %u, actuation %s), MAVLink on %u -> %s:%u",
		   inet_ntoa(xplane.sin_addr), ntohs(xplane.sin_port), xp_listen,
		   act == XP_ACT_DREF ? "dref" : "data25", mav_listen, inet_ntoa(gcs.sin_addr),
		   ntohs(gcs.sin_port));

	while (!stop) {
		struct pollfd pf[2] = {{.fd = xp.fd, .events = POLLIN}, {.fd = mav_fd, .events = POLLIN}};
		int r = poll(pf, 2, 2);
		if (r < 0 && errno != EINTR)
			break;
		if (pf[0].revents & POLLIN) {
			for (int k = 0; k < 256; k++) {
				int got = xp_client_receive(&xp, &frame, hal_wall_us());
				if (got < 0)
					break;
				if (got > 0)
					app_on_frame(&app, &frame);
			}
		}
		if (pf[1].revents & POLLIN) {
			for (int k = 0; k < 256; k++) {
				uint8_t buf[2048];
				struct sockaddr_in from;
				socklen_t fl = sizeof from;
				ssize_t n = recvfrom(mav_fd, buf, sizeof buf, 0, (struct sockaddr *)&from, &fl);
				if (n < 0)
					break;
				/* the ground station is whoever sent the last datagram with an
				 * accepted message (valid checksum, and signature when signing) */
				if (app_on_mavlink(&app, buf, (size_t)n) == 0)
					mav_empty++;   /* not one valid message in it */
				else if (fl >= sizeof from && from.sin_family == AF_INET)
					gcs = from;
			}
		}
		xp_client_poll(&xp, hal_wall_us());
		app_tick(&app);
	}
	xp_client_release(&xp);
	lcm_log_close();
	struct hal_link_stats ls = xp.stats;
	hal_report("exit: %u frames, %u datagrams dropped (%u foreign); MAVLink %u messages, %u bad checksum, "
		   "%u rejected by signing, %u datagrams without a valid message", ls.frames, ls.dropped, ls.foreign,
		   app.mav.rx_msgs, app.mav.rx_dropped, app.mav.rx_unsigned, mav_empty);
	return 0;
}
