// frame_out: what the plant sends and does per frame, shared by octo-sim's UDP server
// (server.cpp) and the in-process plant (plant.cpp), so both give the same bytes.
#pragma once

#include <netinet/in.h>

#include <cstdint>
#include <utility>
#include <vector>

#include "counters.hpp"
#include "faults.hpp"
#include "model.hpp"
#include "options.hpp"
#include "sensors.hpp"
#include "truth.hpp"
#include "xplane_emit.hpp"
#include "xplane_input.hpp"
#include "xplane_proto.hpp"

namespace sim
{

// This frame's DATA datagram as X-Plane sends it (the selected rows the emitter fills,
// in ascending order), through the fault injector when with_faults; what leaves now is
// appended to out. Returns false when the injector withheld the frame (no client can
// answer it); true also when nothing is sent (no row selected, output disabled).
bool frame_data(const Options &o, const XpInput &in, const XpFrame &f, FaultChannel &faults, uint64_t n,
		bool with_faults, std::vector<xp::Bytes> &out);

// The RREF replies due at this frame (each subscription at its rate), grouped per
// destination in subscription order; unknown datarefs reply 0 and are counted.
void rref_replies(const Options &o, XpInput &in, const XpFrame &f, Counters &c,
		  std::vector<std::pair<sockaddr_in, xp::Bytes>> &out);

// One frame: the commanded throttles take effect, the model integrates to (n+1)/rate,
// the sensors advance, the frame is measured and the truth written.
void advance_frame(const Options &o, Model &m, XpInput &in, uint64_t &n, Sensors &s, XpFrame &f, TruthPublisher &truth);

} // namespace sim
