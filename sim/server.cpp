// server: sockets, pacing, lockstep, status; what a frame sends and does is frame_out's.
#include "server.hpp"

#include <arpa/inet.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "beacon.hpp"
#include "counters.hpp"
#include "faults.hpp"
#include "frame_out.hpp"
#include "model.hpp"
#include "net.hpp"
#include "truth.hpp"
#include "xplane_emit.hpp"
#include "xplane_input.hpp"
#include "xplane_proto.hpp"

namespace sim
{

namespace
{

double wall_now()
{
	using namespace std::chrono;
	return duration<double>(steady_clock::now().time_since_epoch()).count();
}

class Server
{
      public:
	Server(const Options &o, const std::atomic<bool> &stop)
	    : o_(o), stop_(stop), model_(o.vehicle), sensors_(o.vehicle, o.seed, o.rate), input_(c_),
	      faults_(o.faults, o.seed, c_)
	{
		model_.set_h_max(o.step);
		model_.set_clock_start(o.start_time);
		input_.target = o.data_out_addr;
		for (int r : o.rows)
			if (r >= 0 && r <= XpInput::kMaxRow)
				input_.selected[static_cast<size_t>(r)] = true;
	}

	int run();

      private:
	// Sends this tick's DATA; returns false when the fault injector withheld it
	// (dropped, or held back for reordering or delay): no client can answer it.
	bool send_frame(bool faults);
	void rref_tick();
	// Processes inputs until `deadline` (wall) or, when until_full, until the 8
	// throttles are commanded. Returns true when they are.
	bool pump(double deadline, bool until_full);
	void advance();
	void status(double now);
	// Announces X-Plane's BECN beacon once a second (wall time).
	void beacon(double now);

	const Options &o_;
	const std::atomic<bool> &stop_;
	Counters c_;
	Model model_;
	Sensors sensors_;
	XpInput input_;
	FaultChannel faults_;
	UdpSocket sock_;
	TruthPublisher truth_;
	XpFrame frame_;
	uint64_t n_ = 0;
	double last_status_ = 0;
	double last_beacon_ = -1e9;
	xp::Bytes becn_;
	sockaddr_in becn_to_{};
	UdpSocket becn_sock_;
	double wall_start_ = 0;
	uint8_t buf_[2048];
};

bool Server::send_frame(bool with_faults)
{
	std::vector<xp::Bytes> out;
	const bool delivered = frame_data(o_, input_, frame_, faults_, n_, with_faults, out);
	for (const auto &b : out) {
		if (sock_.send(b.data(), b.size(), input_.target))
			c_.inc(Counters::TxData);
		else
			c_.inc(Counters::TxError);
	}
	return delivered;
}

void Server::rref_tick()
{
	std::vector<std::pair<sockaddr_in, xp::Bytes>> out;
	rref_replies(o_, input_, frame_, c_, out);
	for (const auto &r : out) {
		if (sock_.send(r.second.data(), r.second.size(), r.first))
			c_.inc(Counters::TxRref);
		else
			c_.inc(Counters::TxError);
	}
}

bool Server::pump(double deadline, bool until_full)
{
	for (;;) {
		sockaddr_in from{};
		size_t len = 0;
		while (sock_.recv(buf_, sizeof buf_, from, len)) {
			if (len > sizeof buf_) { // truncated: no X-Plane request is this long
				c_.inc(Counters::RxDatagrams);
				c_.inc(Counters::RxBadSize);
				continue;
			}
			input_.handle(buf_, len, from);
			if (until_full && (input_.cmd_mask & 0xFFu) == 0xFFu)
				return true;
		}
		if (stop_)
			return false;
		const double now = wall_now();
		if (now >= deadline)
			return (input_.cmd_mask & 0xFFu) == 0xFFu;
		sock_.wait_readable(std::min(deadline - now, 0.25));
	}
}

void Server::advance()
{
	const bool was = model_.crashed();
	advance_frame(o_, model_, input_, n_, sensors_, frame_, truth_);
	if (model_.crashed() && !was) {
		const CrashInfo &c = model_.crash();
		std::fprintf(
			stderr,
			"octo-sim: crashed at t=%.2fs: hit the ground at %.1f m/s, %.0f deg from level (limits %.0f "
			"m/s, %.0f deg); the vehicle stays down until octo-sim restarts\n",
			c.t, c.speed, c.tilt_deg, kCrashSpeed, kCrashTiltDeg);
	}
}

void Server::beacon(double now)
{
	if (becn_.empty() || now - last_beacon_ < 1.0)
		return;
	last_beacon_ = now;
	if (becn_sock_.send(becn_.data(), becn_.size(), becn_to_))
		c_.inc(Counters::TxBeacon);
	else
		c_.inc(Counters::TxBeaconError);
}

void Server::status(double now)
{
	if (now - last_status_ < 1.0)
		return;
	last_status_ = now;
	const BodyState &x = model_.state();
	const double wall = now - wall_start_;
	std::fprintf(stderr,
		     "octo-sim: t=%.2fs frame=%llu x%.1f pos=(%.2f %.2f %.2f)m roll=%.1f pitch=%.1f hdg=%.1f "
		     "rx=%llu tx=%llu%s\n",
		     model_.clock(), static_cast<unsigned long long>(n_), wall > 0 ? model_.t() / wall : 0.0, x.r.x(),
		     x.r.y(), x.r.z(), frame_.roll, frame_.pitch, frame_.heading,
		     static_cast<unsigned long long>(c_[Counters::RxDatagrams]),
		     static_cast<unsigned long long>(c_[Counters::TxData]),
		     model_.crashed()     ? " crashed"
		     : model_.on_ground() ? " landed"
					  : "");
}

int Server::run()
{
	std::string err;
	if (!sock_.open(o_.bind_ip, o_.xp_port, err)) {
		std::fprintf(stderr, "octo-sim: --xp-port %u: %s\n", o_.xp_port, err.c_str());
		return 1;
	}
	if (!o_.lcm_url.empty() && !truth_.open(o_.lcm_url, err)) {
		std::fprintf(stderr, "octo-sim: --lcm: %s\n", err.c_str());
		return 1;
	}
	truth_.set_every(o_.log_every);
	std::fprintf(stderr, "octo-sim: X-Plane %d on %s:%u, Data Output to %s at %g Hz%s\n", o_.xplane_version,
		     o_.bind_ip.c_str(), o_.xp_port, addr_str(input_.target).c_str(), o_.rate,
		     o_.lockstep ? ", lockstep" : "");
	if (o_.beacon) {
		const std::string name = o_.computer_name.empty() ? default_computer_name() : o_.computer_name;
		becn_ = encode_becn(o_.xplane_version, o_.xp_port, name);
		becn_to_.sin_family = AF_INET;
		becn_to_.sin_port = htons(kBeaconPort);
		inet_pton(AF_INET, kBeaconGroup, &becn_to_.sin_addr);
		// without multicast the beacon's sends fail and are counted; the simulator runs on
		if (!becn_sock_.open_multicast_sender(o_.bind_ip, err))
			std::fprintf(stderr, "octo-sim: beacon: %s (sends will be counted as failed)\n", err.c_str());
		std::fprintf(stderr, "octo-sim: beacon as \"%s\" to %s:%u once a second\n", name.c_str(), kBeaconGroup,
			     kBeaconPort);
	}

	xp_measure(model_, input_.effective_throttle(), o_.seed, 0, sensors_, frame_);
	truth_.publish(model_, 0);
	wall_start_ = wall_now();
	const double period = 1.0 / o_.rate;
	double tick = wall_start_;
	bool started = !o_.lockstep;
	while (!stop_) {
		const bool delivered = send_frame(started);
		rref_tick();
		beacon(wall_now());
		if (o_.verbose)
			status(wall_now());
		if (o_.duration > 0 && model_.t() >= o_.duration - 1e-9)
			break;
		if (o_.lockstep) {
			if (!started) {
				tick += period;
				const double now = wall_now();
				if (tick < now - 1.0)
					tick = now;
				if (!pump(tick, true))
					continue; // still waiting: re-send frame 0
				started = true;
			} else if (!delivered) {
				// A frame the fault injector withheld gets no answer: waiting for one would
				// only let a late answer to an earlier frame count for this one (and every
				// later answer then act a frame late). Advance with the throttles held, as
				// X-Plane does when a client misses a frame.
				c_.inc(Counters::LockstepWithheld);
			} else if (!pump(wall_now() + o_.lockstep_timeout, true)) {
				if (stop_)
					break;
				c_.inc(Counters::LockstepTimeouts);
			}
		} else {
			tick += period;
			const double now = wall_now();
			if (tick < now - 1.0)
				tick = now; // fell far behind (suspended): resynchronise
			pump(tick, false);
			if (stop_)
				break;
		}
		advance();
	}
	std::fprintf(stderr, "octo-sim: stopped at t=%.3fs after %llu frames; counters %s\n", model_.clock(),
		     static_cast<unsigned long long>(n_), c_.json().c_str());
	return 0;
}

} // namespace

int run_server(const Options &o, const std::atomic<bool> &stop)
{
	Server s(o, stop);
	return s.run();
}

} // namespace sim
