// plant: octo-sim's plant behind a C interface (plant.h). The per-frame work is
// frame_out's, as in octo-sim's lockstep server (server.cpp): the same DATA rows,
// fault injector, RREF scheduling, command, integration, measurement and truth, in
// the same order, so the same inputs give the same bytes; only the sockets are gone.
#include "plant.h"

#include <arpa/inet.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "counters.hpp"
#include "faults.hpp"
#include "frame_out.hpp"
#include "model.hpp"
#include "net.hpp"
#include "options.hpp"
#include "truth.hpp"
#include "xplane_emit.hpp"
#include "xplane_input.hpp"
#include "xplane_proto.hpp"

namespace
{

struct Out {
	xp::Bytes b;
	sockaddr_in to;
};

} // namespace

struct octo_plant {
	explicit octo_plant(const sim::Options &opt)
	    : o(opt), model(o.vehicle), sensors(o.vehicle, o.seed, o.rate), input(c), faults(o.faults, o.seed, c)
	{
		model.set_h_max(o.step);
		model.set_clock_start(o.start_time);
		input.target = o.data_out_addr;
		for (int r : o.rows)
			if (r >= 0 && r <= sim::XpInput::kMaxRow)
				input.selected[static_cast<size_t>(r)] = true;
		sim::xp_measure(model, input.effective_throttle(), o.seed, 0, sensors, frame);
	}

	void send(xp::Bytes &&b, const sockaddr_in &to) { out.push_back(Out{std::move(b), to}); }
	bool send_frame(bool with_faults);
	void rref_tick();

	sim::Options o;
	sim::Counters c;
	sim::Model model;
	sim::Sensors sensors;
	sim::XpInput input;
	sim::FaultChannel faults;
	sim::TruthPublisher truth;
	sim::XpFrame frame;
	uint64_t n = 0;
	bool truth0 = false; // frame 0's truth written
	std::deque<Out> out;
	std::vector<xp::Bytes> sent; // this frame's DATA datagrams (send_frame)
	std::string counters_json;
};

bool octo_plant::send_frame(bool with_faults)
{
	sent.clear(); // kept between frames: its storage is allocated once
	const bool delivered = sim::frame_data(o, input, frame, faults, n, with_faults, sent);
	for (auto &b : sent) {
		c.inc(sim::Counters::TxData);
		send(std::move(b), input.target);
	}
	return delivered;
}

void octo_plant::rref_tick()
{
	std::vector<std::pair<sockaddr_in, xp::Bytes>> replies;
	sim::rref_replies(o, input, frame, c, replies);
	for (auto &r : replies) {
		c.inc(sim::Counters::TxRref);
		send(std::move(r.second), r.first);
	}
}

extern "C" {

octo_plant *octo_plant_create(const char *prog, int argc, char **argv, int *status)
{
	// Flags that belong to octo-sim's server, not to the plant.
	static const char *const refused[] = {
		"--xp-port",  "--bind",    "--data-out", "--lockstep",  "--lockstep-timeout", "--lcm",
		"--duration", "--verbose", "-v",         "--no-beacon", "--computer-name"};
	for (int i = 1; i < argc; i++)
		for (const char *r : refused)
			if (!std::strcmp(argv[i], r)) {
				std::fprintf(stderr, "%s: %s: not an option of the in-process plant (see --help)\n",
					     prog, argv[i]);
				*status = 2;
				return nullptr;
			}
	sim::Options o;
	int rc = sim::parse_options(argc, argv, o);
	if (rc >= 0) {
		*status = rc;
		return nullptr;
	}
	*status = 0;
	return new octo_plant(o);
}

void octo_plant_destroy(octo_plant *p) { delete p; }

int octo_plant_open_truth(octo_plant *p, const char *url)
{
	std::string err;
	if (!p->truth.open(url, err)) {
		std::fprintf(stderr, "octo-sil: --lcm-sim: %s\n", err.c_str());
		return -1;
	}
	p->truth.set_every(p->o.log_every);
	return 0;
}

void octo_plant_receive(octo_plant *p, const uint8_t *buf, size_t len, uint32_t from_ip, uint16_t from_port)
{
	sockaddr_in from{};
	from.sin_family = AF_INET;
	from.sin_addr.s_addr = from_ip;
	from.sin_port = htons(from_port);
	p->input.handle(buf, len, from);
}

bool octo_plant_emit(octo_plant *p, bool faults)
{
	if (!p->truth0) {
		p->truth.publish(p->model, 0);
		p->truth0 = true;
	}
	bool delivered = p->send_frame(faults);
	p->rref_tick();
	return delivered;
}

long octo_plant_pop(octo_plant *p, uint8_t *buf, size_t cap, uint32_t *to_ip, uint16_t *to_port)
{
	if (p->out.empty())
		return -1;
	Out &o = p->out.front();
	size_t n = o.b.size() < cap ? o.b.size() : cap;
	std::memcpy(buf, o.b.data(), n);
	long len = static_cast<long>(o.b.size());
	if (to_ip)
		*to_ip = o.to.sin_addr.s_addr;
	if (to_port)
		*to_port = ntohs(o.to.sin_port);
	p->out.pop_front();
	return len;
}

bool octo_plant_commanded(const octo_plant *p) { return (p->input.cmd_mask & 0xFFu) == 0xFFu; }

void octo_plant_advance(octo_plant *p)
{
	sim::advance_frame(p->o, p->model, p->input, p->n, p->sensors, p->frame, p->truth);
}

void octo_plant_truth(const octo_plant *p, struct octo_plant_truth *t)
{
	const sim::BodyState &x = p->model.state();
	t->t = p->model.clock();
	t->t0 = p->o.start_time;
	t->frame = p->n;
	for (int i = 0; i < 3; i++) {
		t->pos_i[i] = x.r[i];
		t->vel_i[i] = x.v[i];
		t->omega_b[i] = x.w[i];
	}
	t->q_ib[0] = x.q.w();
	t->q_ib[1] = x.q.x();
	t->q_ib[2] = x.q.y();
	t->q_ib[3] = x.q.z();
	t->on_ground = p->model.on_ground();
	t->crashed = p->model.crashed();
	t->crash_t = p->model.crash().t;
	t->crash_speed = p->model.crash().speed;
	t->crash_tilt_deg = p->model.crash().tilt_deg;
}

double octo_plant_rate(const octo_plant *p) { return p->o.rate; }

const char *octo_plant_counters(octo_plant *p)
{
	p->counters_json = p->c.json();
	return p->counters_json.c_str();
}

} // extern "C"
