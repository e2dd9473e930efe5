// server: the run loop. Real time (paced like X-Plane: one frame per 1/rate of
// wall time, inputs applied at the next frame) or lockstep (docs/running.md: advance
// when the 8 throttles have been commanded or on timeout; before the first
// command, time stands still and frame 0 is re-sent at the real-time rate).
#pragma once

#include <atomic>

#include "options.hpp"

namespace sim
{

// Runs until --duration or *stop; returns the exit status.
int run_server(const Options &o, const std::atomic<bool> &stop);

} // namespace sim
