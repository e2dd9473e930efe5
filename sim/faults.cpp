// faults: drop, burst, delay, duplicate, reorder, in that order of decision.
#include "faults.hpp"

#include "rng.hpp"

namespace sim
{

std::vector<xp::Bytes> FaultChannel::submit(uint64_t frame, xp::Bytes dgram)
{
	Rng r(seed_, Stream::Fault, frame);
	// fixed draw order whatever flags are set
	const double u_drop = r.uniform(), u_burst = r.uniform(), u_dup = r.uniform(), u_reo = r.uniform();

	std::vector<xp::Bytes> out;
	bool lost = false;
	if (burst_left_ > 0) {
		burst_left_--;
		lost = true;
	} else if (p_.burst > 0 && u_burst < p_.burst_prob) {
		burst_left_ = p_.burst - 1;
		lost = true;
	}
	if (!lost && u_drop < p_.drop)
		lost = true;

	// frames delayed earlier are due now whatever happens to this one
	std::vector<xp::Bytes> ready;
	if (p_.delay_frames > 0) {
		if (!lost)
			delayed_.push_back({frame + static_cast<uint64_t>(p_.delay_frames), std::move(dgram)});
		while (!delayed_.empty() && delayed_.front().release <= frame) {
			ready.push_back(std::move(delayed_.front().b));
			delayed_.pop_front();
		}
	} else if (!lost) {
		ready.push_back(std::move(dgram));
	}
	if (lost)
		c_.inc(Counters::FaultDropped);

	for (auto &b : ready) {
		const int copies = (u_dup < p_.duplicate) ? 2 : 1;
		if (copies == 2)
			c_.inc(Counters::FaultDuplicated);
		if (held_.empty() && u_reo < p_.reorder) {
			c_.inc(Counters::FaultReordered);
			for (int k = 0; k < copies; k++)
				held_.push_back(b);
			continue;
		}
		for (int k = 0; k < copies; k++)
			out.push_back(b);
		for (auto &h : held_)
			out.push_back(std::move(h));
		held_.clear();
	}
	return out;
}

} // namespace sim
