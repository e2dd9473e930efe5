/* xp_beacon.c - finding X-Plane by its BECN beacon (see xp_beacon.h). */
#define _DEFAULT_SOURCE /* struct ip_mreq */
#include "xp_beacon.h"

#include <arpa/inet.h>
#include <errno.h>
#include <poll.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define BECN_GROUP "239.255.1.1"
#define BECN_PORT 49707

static uint32_t le32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

int xp_beacon_decode(const uint8_t *p, size_t n, struct xp_beacon *out)
{
	if (n < 22 || memcmp(p, "BECN", 4) != 0)
		return -1;
	const uint8_t *b = p + 5;
	uint32_t host = le32(b + 2), role = le32(b + 10);
	uint16_t port = (uint16_t)(b[14] | b[15] << 8);
	if (b[0] != 1 || host != 1 || role != 1 || port == 0)
		return -1; /* not a master X-Plane (Plane-Maker, external visual, IOS) */
	const uint8_t *name = p + 21;
	const uint8_t *nul = memchr(name, 0, n - 21);
	if (!nul)
		return -1;
	out->major = b[0];
	out->minor = b[1];
	out->version = (int32_t)le32(b + 6);
	out->addr.sin_port = htons(port);
	size_t len = (size_t)(nul - name);
	if (len >= sizeof out->name)
		len = sizeof out->name - 1;
	memcpy(out->name, name, len);
	out->name[len] = 0;
	for (size_t i = 0; i < len; i++)
		if (out->name[i] < 32 || out->name[i] > 126)
			out->name[i] = '?';
	return 0;
}

/* True when addr is one of this host's own addresses (a socket can bind to it). */
static int is_local(struct in_addr addr)
{
	int s = socket(AF_INET, SOCK_DGRAM, 0);
	if (s < 0)
		return 0;
	struct sockaddr_in a;
	memset(&a, 0, sizeof a);
	a.sin_family = AF_INET;
	a.sin_addr = addr;
	int ok = bind(s, (struct sockaddr *)&a, sizeof a) == 0;
	close(s);
	return ok;
}

static bool stop_pending(const sigset_t *stop_set)
{
	sigset_t pending;
	if (sigpending(&pending))
		return false;
	for (int sig = 1; sig < NSIG; sig++)
		if (sigismember(stop_set, sig) == 1 && sigismember(&pending, sig) == 1)
			return true;
	return false;
}

static double now_s(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

int xp_beacon_find(double timeout_s, const sigset_t *stop_set, struct xp_beacon *out)
{
	int fd = socket(AF_INET, SOCK_DGRAM, 0);
	if (fd < 0) {
		fprintf(stderr, "octo-fw: --xplane auto: socket: %s\n", strerror(errno));
		return -1;
	}
	int one = 1;
	(void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
	struct sockaddr_in a;
	memset(&a, 0, sizeof a);
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_ANY);
	a.sin_port = htons(BECN_PORT);
	struct ip_mreq mr;
	memset(&mr, 0, sizeof mr);
	inet_pton(AF_INET, BECN_GROUP, &mr.imr_multiaddr);
	mr.imr_interface.s_addr = htonl(INADDR_ANY);
	if (bind(fd, (struct sockaddr *)&a, sizeof a) < 0 ||
	    setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mr, sizeof mr) < 0) {
		fprintf(stderr, "octo-fw: --xplane auto: cannot listen for beacons on %s:%d: %s\n", BECN_GROUP,
			BECN_PORT, strerror(errno));
		close(fd);
		return -1;
	}
	fprintf(stderr, "octo-fw: waiting up to %.0f s for an X-Plane beacon on %s:%d\n", timeout_s, BECN_GROUP,
		BECN_PORT);
	const double deadline = now_s() + timeout_s;
	int found = -1;
	bool stop = false;
	while (found < 0 && !(stop = stop_pending(stop_set))) {
		double left = deadline - now_s();
		if (left <= 0.0)
			break;
		struct pollfd pf = {.fd = fd, .events = POLLIN};
		if (poll(&pf, 1, left > 0.25 ? 250 : (int)(left * 1000.0) + 1) <= 0)
			continue;
		uint8_t buf[1500];
		struct sockaddr_in from;
		socklen_t fl = sizeof from;
		ssize_t n = recvfrom(fd, buf, sizeof buf, 0, (struct sockaddr *)&from, &fl);
		if (n <= 0 || fl < sizeof from)
			continue;
		memset(out, 0, sizeof *out);
		if (xp_beacon_decode(buf, (size_t)n, out) == 0) {
			out->addr.sin_family = AF_INET;
			out->addr.sin_addr = from.sin_addr;
			/* An X-Plane on this host announces from its outgoing interface; it
			 * (and octo-sim, bound to the loopback by default) is reached on the
			 * loopback, and its datagrams come from there too. */
			if (is_local(from.sin_addr))
				out->addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
			found = 0;
		}
	}
	close(fd);
	if (found < 0 && !stop)
		fprintf(stderr,
			"octo-fw: --xplane auto: no X-Plane beacon within %.0f s (is X-Plane running on "
			"this network, with multicast reaching this host?)\n",
			timeout_s);
	return found;
}
