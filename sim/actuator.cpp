// actuator: thrust curve, drift and the transport delay line.
#include "actuator.hpp"

#include <algorithm>
#include <limits>

namespace sim
{

double thrust_curve(double c, double s)
{
	s = std::min(1.0, std::max(0.0, s));
	return (1.0 - c) * s + c * s * s;
}

double drift_factor(const VehicleParams &p, double t) { return std::max(0.0, 1.0 + p.kf_drift_per_min * t / 60.0); }

void DelayLine::apply_due(double t, RotorArray &current)
{
	while (!q_.empty() && q_.front().t <= t + 1e-12) {
		current = q_.front().u;
		q_.pop_front();
	}
}

double DelayLine::next_after(double t) const
{
	for (const auto &e : q_)
		if (e.t > t + 1e-12)
			return e.t;
	return std::numeric_limits<double>::infinity();
}

} // namespace sim
