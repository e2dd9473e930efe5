/*
 * plant.h - octo-sim's plant as a library with a C interface: the model, the
 * actuator, the fault injector, X-Plane's receiving side (decoder) and its Data
 * Output and RREF replies (encoder), and the truth log, without sockets.
 *
 * The caller moves the bytes. One lockstep tick, as octo-sim --lockstep does it:
 *
 *   octo_plant_emit(p, started)     this frame's DATA (through the fault injector
 *                                   once started) and the due RREF replies go to
 *                                   the output queue; returns whether the DATA
 *                                   left (a withheld frame gets no answer)
 *   octo_plant_pop(p, ...)          take them out, one datagram at a time
 *   octo_plant_receive(p, ...)      hand the client's datagrams in
 *   octo_plant_commanded(p)         all 8 throttles commanded since the last advance?
 *   octo_plant_advance(p)           apply the throttles, integrate one frame, measure,
 *                                   write the truth
 *
 * Every datagram is the byte string octo-sim would send or receive over UDP.
 * Addresses are IPv4 in network byte order, ports in host byte order; they only
 * matter where X-Plane uses them (RREF replies go back to the requester).
 */
#ifndef OCTO_PLANT_H
#define OCTO_PLANT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct octo_plant octo_plant;

/* Creates a plant from octo-sim's simulation and fault flags (argv[0] is the
 * program name; --vehicle, --ideal, --seed, --rate, --step, --start-time, --xplane-version,
 * --rows, --sensors, --drop, --burst, --burst-prob, --delay-frames, --duplicate, --reorder,
 * --shift-origin, --fail-rotor, --imu-spike, --imu-spike-gyro, --imu-spike-accel, --stuck-rpm).
 * Network and run-loop flags are refused. On error returns NULL, *status = 2 and
 * the message on stderr; after --help *status = 0 and NULL. `prog` names the
 * program in messages. */
octo_plant *octo_plant_create(const char *prog, int argc, char **argv, int *status);
void octo_plant_destroy(octo_plant *p);

/* The truth log (LCM URL as octo-sim --lcm); 0 or -1 with the reason on stderr. */
int octo_plant_open_truth(octo_plant *p, const char *url);

void octo_plant_receive(octo_plant *p, const uint8_t *buf, size_t len, uint32_t from_ip, uint16_t from_port);
bool octo_plant_emit(octo_plant *p, bool faults);
/* Copies the oldest queued datagram into buf (at most cap bytes) and removes it;
 * returns its length, or -1 when the queue is empty. */
long octo_plant_pop(octo_plant *p, uint8_t *buf, size_t cap, uint32_t *to_ip, uint16_t *to_port);
bool octo_plant_commanded(const octo_plant *p);
void octo_plant_advance(octo_plant *p);

struct octo_plant_truth {
	double t;        /* the plant's clock, s (starts at t0) */
	double t0;       /* the clock at frame 0 (--start-time), s */
	uint64_t frame;  /* frames advanced */
	double pos_i[3]; /* S_I (north, west, up), m */
	double vel_i[3];
	double q_ib[4];    /* [w x y z] */
	double omega_b[3]; /* rad/s, FLU */
	bool on_ground;
	bool crashed;                                /* hit the ground too tilted or too fast: the body stays down */
	double crash_t, crash_speed, crash_tilt_deg; /* when, m/s towards the ground, deg */
};
void octo_plant_truth(const octo_plant *p, struct octo_plant_truth *out);
double octo_plant_rate(const octo_plant *p);
/* The simulator's counters as one line of JSON (valid until the next call). */
const char *octo_plant_counters(octo_plant *p);

#ifdef __cplusplus
}
#endif

#endif /* OCTO_PLANT_H */
