// frame_out: the per-frame output and step of the plant (see frame_out.hpp).
#include "frame_out.hpp"

#include <array>
#include <cmath>

#include "net.hpp"

namespace sim
{

bool frame_data(const Options &o, const XpInput &in, const XpFrame &f, FaultChannel &faults, uint64_t n,
		bool with_faults, std::vector<xp::Bytes> &out)
{
	if (!in.target_enabled)
		return true;
	// the rows on the stack: this runs once a frame
	std::array<xp::DataRow, XpInput::kMaxRow + 1> rows;
	size_t n_rows = 0;
	for (int r : xp_supported_rows())
		if (in.selected[static_cast<size_t>(r)] && xp_row_served(r, o.vehicle.sensors))
			rows[n_rows++] = xp_row(f, r, o.xplane_version);
	if (n_rows == 0)
		return true; // X-Plane sends nothing while no row is selected
	xp::Bytes d;
	xp::encode_data(rows.data(), n_rows, d);
	if (with_faults && o.faults.any()) {
		std::vector<xp::Bytes> sent = faults.submit(n, std::move(d));
		for (auto &b : sent)
			out.push_back(std::move(b));
		return !sent.empty();
	}
	out.push_back(std::move(d));
	return true;
}

void rref_replies(const Options &o, XpInput &in, const XpFrame &f, Counters &c,
		  std::vector<std::pair<sockaddr_in, xp::Bytes>> &out)
{
	if (in.subs.empty())
		return;
	std::vector<std::pair<sockaddr_in, std::vector<std::pair<int32_t, float>>>> groups;
	for (auto &s : in.subs) {
		s.phase += s.freq / o.rate;
		if (s.phase < 1.0)
			continue;
		s.phase -= std::floor(s.phase);
		float v = 0.0f;
		if (!xp_dataref_served(s.path, o.vehicle.sensors) ||
		    !xp_dataref(f, s.path, o.xplane_version, in.override_on, in.thro_use, in.thro, v))
			c.inc(Counters::RrefUnknown);
		size_t g = 0;
		while (g < groups.size() && !same_addr(groups[g].first, s.to))
			g++;
		if (g == groups.size())
			groups.push_back({s.to, {}});
		groups[g].second.push_back({s.index, v});
	}
	for (const auto &g : groups)
		for (auto &b : xp::encode_rref_replies(g.second))
			out.push_back({g.first, std::move(b)});
}

void advance_frame(const Options &o, Model &m, XpInput &in, uint64_t &n, Sensors &s, XpFrame &f, TruthPublisher &truth)
{
	std::array<double, kRotors> u = in.effective_throttle();
	m.command(u);
	in.cmd_mask = 0;
	n++;
	m.advance_to(static_cast<double>(n) / o.rate);
	s.advance(m, n);
	xp_measure(m, u, o.seed, n, s, f);
	s.hold_stuck_rpm(m.clock(), f.rpm);
	truth.publish(m, n);
}

} // namespace sim
