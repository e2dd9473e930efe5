// actuator: what happens between a throttle command and a rotor's force:
// transport delay (a time-stamped queue), first-order lag (integrated by the
// model as part of its state), thrust curve, per-rotor effectiveness, k_f drift.
#pragma once

#include <array>
#include <deque>

#include "vehicle.hpp"

namespace sim
{

using RotorArray = std::array<double, kRotors>;

// g(s) = (1 - c) s + c s^2: linear for c = 0; s is clamped to [0, 1].
double thrust_curve(double c, double s);

// Drift factor of k_f and k_tau at time t (battery sag): 1 + rate * t / 60, >= 0.
double drift_factor(const VehicleParams &p, double t);

// Delay line of throttle commands: a command given at t takes effect at t + delay.
class DelayLine
{
      public:
	explicit DelayLine(double delay) : delay_(delay) {}

	void push(double t, const RotorArray &u) { q_.push_back({t + delay_, u}); }
	// Applies every queued command due at or before t (+1e-12) to `current`.
	void apply_due(double t, RotorArray &current);
	// Time of the next queued change after t, or +inf.
	double next_after(double t) const;
	double delay() const { return delay_; }

      private:
	struct Entry {
		double t;
		RotorArray u;
	};
	double delay_;
	std::deque<Entry> q_;
};

} // namespace sim
