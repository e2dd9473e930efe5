/*
 * pingpong.c - the UDP limits of the lockstep design, for `make bench` (tests/bench/bench.py).
 *
 *   pingpong pp FRAMES OUT_BYTES BACK_COUNT BACK_BYTES
 *       Two processes (fork) over loopback UDP: the "plant" sends one OUT_BYTES datagram
 *       per frame, the "firmware" answers each with BACK_COUNT datagrams of BACK_BYTES,
 *       and the plant waits for all of them before the next frame; blocking calls, no
 *       work. The plant side prints one JSON line:
 *       {"frames": N, "wall_s": T, "frames_per_s": F}  (after 200 warm-up frames)
 *       The octo-sim/octo-fw pattern: DATA of 6 rows (5 + 6 x 36 = 221 bytes) out,
 *       8 DREFs of 509 bytes back (--actuation dref) or one DATA row 25 of 41 bytes (data25).
 *
 *   pingpong client XP_PORT LISTEN_PORT dref|data25 [THROTTLE]
 *       The tightest possible X-Plane client of `octo-sim --lockstep`: listens on
 *       LISTEN_PORT (octo-sim's --data-out), selects rows 1 16 17 21 35 36 (as octo-fw does)
 *       and answers every DATA frame with the 8 throttles (THROTTLE, default 0.0935) as one
 *       row 25 record or 8 DREFs; stops when no frame came for 1 s and prints
 *       {"frames": N, "wall_s": T, "frames_per_s": F} (from the first frame answered to
 *       the last frame received).
 */
#define _POSIX_C_SOURCE 200809L
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define WARMUP 200

static double now_s(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int udp_bound(uint16_t port)
{
	int fd = socket(AF_INET, SOCK_DGRAM, 0);
	if (fd < 0) {
		perror("socket");
		exit(1);
	}
	int big = 1 << 20;
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(port)};
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (bind(fd, (struct sockaddr *)&a, sizeof a) < 0) {
		perror("bind");
		exit(1);
	}
	return fd;
}

static uint16_t port_of(int fd)
{
	struct sockaddr_in a;
	socklen_t n = sizeof a;
	getsockname(fd, (struct sockaddr *)&a, &n);
	return ntohs(a.sin_port);
}

static void connect_to(int fd, uint16_t port)
{
	struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons(port)};
	a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	if (connect(fd, (struct sockaddr *)&a, sizeof a) < 0) {
		perror("connect");
		exit(1);
	}
}

static int pingpong(long frames, size_t out_b, int back_n, size_t back_b)
{
	int plant = udp_bound(0), fw = udp_bound(0);
	connect_to(plant, port_of(fw));
	connect_to(fw, port_of(plant));
	static char buf[65536];
	memset(buf, 'x', sizeof buf);
	memcpy(buf, "DATA", 4);
	long total = frames + WARMUP;
	pid_t pid = fork();
	if (pid < 0) {
		perror("fork");
		return 1;
	}
	if (pid == 0) { /* the firmware side */
		close(plant);
		for (long i = 0; i < total; i++) {
			if (recv(fw, buf, sizeof buf, 0) < 0)
				_exit(1);
			for (int k = 0; k < back_n; k++)
				if (send(fw, buf, back_b, 0) < 0)
					_exit(1);
		}
		_exit(0);
	}
	close(fw);
	double t0 = 0;
	for (long i = 0; i < total; i++) {
		if (i == WARMUP)
			t0 = now_s();
		if (send(plant, buf, out_b, 0) < 0) {
			perror("send");
			return 1;
		}
		for (int k = 0; k < back_n; k++)
			if (recv(plant, buf, sizeof buf, 0) < 0) {
				perror("recv");
				return 1;
			}
	}
	double wall = now_s() - t0;
	int st = 0;
	waitpid(pid, &st, 0);
	printf("{\"frames\": %ld, \"wall_s\": %.6f, \"frames_per_s\": %.1f}\n", frames, wall, (double)frames / wall);
	return WIFEXITED(st) && WEXITSTATUS(st) == 0 ? 0 : 1;
}

static size_t put_header(char *b, const char *tag)
{
	memcpy(b, tag, 4);
	b[4] = 0;
	return 5;
}

static int client(uint16_t xp_port, uint16_t listen_port, int dref, float thr)
{
	int fd = udp_bound(listen_port);
	struct sockaddr_in xp = {.sin_family = AF_INET, .sin_port = htons(xp_port)};
	xp.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
	struct timeval tv = {1, 0};
	setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);

	char b[512];
	static const int32_t rows[] = {1, 16, 17, 21, 35, 36};
	size_t n = put_header(b, "DSEL");
	for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++, n += 4)
		memcpy(b + n, &rows[i], 4);
	const size_t n_dsel = n;
	sendto(fd, b, n_dsel, 0, (struct sockaddr *)&xp, sizeof xp);

	/* answers, prepared once */
	char row25[41];
	n = put_header(row25, "DATA");
	int32_t idx = 25;
	memcpy(row25 + n, &idx, 4);
	for (int j = 0; j < 8; j++)
		memcpy(row25 + n + 4 + 4 * j, &thr, 4);
	char drefs[9][509];
	for (int j = 0; j < 9; j++) {
		memset(drefs[j], 0, sizeof drefs[j]);
		put_header(drefs[j], "DREF");
		float v = j < 8 ? thr : 1.0f;
		memcpy(drefs[j] + 5, &v, 4);
		if (j < 8)
			snprintf(drefs[j] + 9, 500, "sim/flightmodel/engine/ENGN_thro_use[%d]", j);
		else
			snprintf(drefs[j] + 9, 500, "sim/operation/override/override_throttles");
	}
	if (dref)
		sendto(fd, drefs[8], 509, 0, (struct sockaddr *)&xp, sizeof xp);

	long frames = 0;
	double t_first = 0, t_last = 0;
	static char rx[65536];
	/* until the first frame: DSEL (and the override) again every 50 ms, for up to 10 s, in
	 * case octo-sim was not listening yet */
	struct timeval tv_short = {0, 50000};
	setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv_short, sizeof tv_short);
	for (int tries = 0; tries < 200; tries++) {
		ssize_t r = recv(fd, rx, sizeof rx, MSG_PEEK);
		if (r >= 0)
			break;
		sendto(fd, b, n_dsel, 0, (struct sockaddr *)&xp, sizeof xp);
		if (dref)
			sendto(fd, drefs[8], 509, 0, (struct sockaddr *)&xp, sizeof xp);
	}
	setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
	for (;;) {
		ssize_t r = recv(fd, rx, sizeof rx, 0);
		if (r < 0)
			break; /* 1 s of silence: octo-sim has stopped */
		if (r < 5 || memcmp(rx, "DATA", 4) != 0)
			continue;
		if (dref) {
			for (int j = 0; j < 8; j++)
				sendto(fd, drefs[j], 509, 0, (struct sockaddr *)&xp, sizeof xp);
		} else {
			sendto(fd, row25, sizeof row25, 0, (struct sockaddr *)&xp, sizeof xp);
		}
		t_last = now_s();
		if (frames++ == 0)
			t_first = t_last;
	}
	/* frames after the first answered one (the first may be a repeat of frame 0) */
	long timed = frames > 1 ? frames - 1 : 0;
	double wall = t_last - t_first;
	printf("{\"frames\": %ld, \"wall_s\": %.6f, \"frames_per_s\": %.1f}\n", timed, wall,
	       wall > 0 ? (double)timed / wall : 0.0);
	return frames > 1 ? 0 : 1;
}

int main(int argc, char **argv)
{
	if (argc == 6 && !strcmp(argv[1], "pp"))
		return pingpong(atol(argv[2]), (size_t)atol(argv[3]), atoi(argv[4]), (size_t)atol(argv[5]));
	if ((argc == 5 || argc == 6) && !strcmp(argv[1], "client"))
		return client((uint16_t)atoi(argv[2]), (uint16_t)atoi(argv[3]), !strcmp(argv[4], "dref"),
			      argc == 6 ? (float)atof(argv[5]) : 0.0935f);
	fprintf(stderr, "usage: pingpong pp FRAMES OUT_BYTES BACK_COUNT BACK_BYTES\n"
			"       pingpong client XP_PORT LISTEN_PORT dref|data25 [THROTTLE]\n");
	return 2;
}
