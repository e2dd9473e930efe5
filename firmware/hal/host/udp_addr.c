/*
 * udp_addr.c - what octo-fw and octo-sil share of their UDP set-up: ports and
 * HOST:PORT from the command line (errors name the program, the flag and the
 * value) and the non-blocking MAVLink socket bound on all addresses.
 */
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "host.h"

int udp_parse_port(const char *prog, const char *flag, const char *s, uint16_t *out)
{
	char *e = NULL;
	long v = strtol(s, &e, 10);
	if (!*s || *e || v < 1 || v > 65535) {
		fprintf(stderr, "%s: %s: '%s' is not a port (1..65535)\n", prog, flag, s);
		return -1;
	}
	*out = (uint16_t)v;
	return 0;
}

int udp_parse_hostport(const char *prog, const char *flag, const char *s, struct sockaddr_in *out)
{
	char host[256];
	const char *colon = strrchr(s, ':');
	if (!colon || colon == s || (size_t)(colon - s) >= sizeof host) {
		fprintf(stderr, "%s: %s: '%s' is not HOST:PORT\n", prog, flag, s);
		return -1;
	}
	memcpy(host, s, (size_t)(colon - s));
	host[colon - s] = 0;
	uint16_t port;
	if (udp_parse_port(prog, flag, colon + 1, &port))
		return -1;
	struct addrinfo hints, *res = NULL;
	memset(&hints, 0, sizeof hints);
	hints.ai_family = AF_INET;
	hints.ai_socktype = SOCK_DGRAM;
	if (getaddrinfo(host, NULL, &hints, &res) || !res) {
		fprintf(stderr, "%s: %s: unknown host '%s'\n", prog, flag, host);
		return -1;
	}
	memcpy(out, res->ai_addr, sizeof *out);
	freeaddrinfo(res);
	out->sin_port = htons(port);
	return 0;
}

int udp_open_ground(const char *prog, uint16_t port)
{
	int fd = socket(AF_INET, SOCK_DGRAM, 0);
	if (fd < 0) {
		fprintf(stderr, "%s: MAVLink socket: %s\n", prog, strerror(errno));
		return -1;
	}
	struct sockaddr_in a;
	memset(&a, 0, sizeof a);
	a.sin_family = AF_INET;
	a.sin_addr.s_addr = htonl(INADDR_ANY);
	a.sin_port = htons(port);
	if (bind(fd, (struct sockaddr *)&a, sizeof a) < 0) {
		fprintf(stderr, "%s: cannot bind MAVLink port %u: %s\n", prog, port, strerror(errno));
		close(fd);
		return -1;
	}
	(void)fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	return fd;
}
