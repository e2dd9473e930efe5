// truth: ground truth on LCM channel OCTO_TRUTH (type octo.truth_t), one message
// per simulated frame (or every Nth, set_every). A "file://PATH[?mode=w]" URL is written directly as an LCM
// event log stamped with SIMULATED time (byte-identical logs in lockstep);
// any other URL goes through lcm_publish.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "model.hpp"

namespace sim
{

class TruthPublisher
{
      public:
	TruthPublisher();
	~TruthPublisher();
	// false with err set when the URL cannot be opened
	bool open(const std::string &url, std::string &err);
	// keep every Nth frame only (frame % every == 0); 1: all
	void set_every(unsigned every);
	void publish(const Model &m, uint64_t frame);
	bool active() const;

      private:
	struct Impl;
	std::unique_ptr<Impl> d_;
};

} // namespace sim
