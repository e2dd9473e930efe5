// faults: seeded fault injection on the DATA output stream (--drop, --burst,
// --delay-frames, --duplicate, --reorder). Every decision is a function of
// (seed, frame index), so a lockstep run with faults is still reproducible.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "counters.hpp"
#include "xplane_proto.hpp"

namespace sim
{

struct FaultParams {
	double drop = 0;           // probability that a frame is lost
	int burst = 0;             // length of a burst of consecutive lost frames (0: none)
	double burst_prob = 0.005; // probability per frame that a burst starts
	int delay_frames = 0;      // every frame leaves K frames late
	double duplicate = 0;      // probability that a frame is sent twice
	double reorder = 0;        // probability that a frame is held back and sent after the next
	bool any() const { return drop > 0 || burst > 0 || delay_frames > 0 || duplicate > 0 || reorder > 0; }
};

class FaultChannel
{
      public:
	FaultChannel(const FaultParams &p, uint64_t seed, Counters &c) : p_(p), seed_(seed), c_(c) {}
	// One DATA datagram of frame `frame` (frames submitted in increasing order);
	// returns what leaves now, in order.
	std::vector<xp::Bytes> submit(uint64_t frame, xp::Bytes dgram);

      private:
	struct Delayed {
		uint64_t release;
		xp::Bytes b;
	};
	FaultParams p_;
	uint64_t seed_;
	Counters &c_;
	int burst_left_ = 0;
	std::deque<Delayed> delayed_;
	std::vector<xp::Bytes> held_; // reorder: waits for the next frame
};

} // namespace sim
