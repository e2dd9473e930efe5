// sensors: a flight controller's own sensors as octo-sim serves them (docs/sensors.md).
// The IMU (specific force and body rates) with scale errors, a constant bias plus a
// random walk per axis and the rotors' vibration seen through an anti-alias filter at
// the IMU's internal sample rate; the ESCs' rotor speed as bidirectional DShot reports
// it. Everything random is drawn from (seed, stream, frame) on streams of its own.
#pragma once

#include <Eigen/Core>

#include "model.hpp"

namespace sim
{

// Rotor speed (rad/s) for the actuator output s at time t. A fixed propeller's thrust
// goes with speed^2, and the thrust at s is k_f d(t) g(s) (drift included), so the
// speed is speed_max sqrt(d(t) g(s)): it follows the lagged, delayed throttle as the
// thrust does. rotor_scale is the propeller's effectiveness and leaves the speed alone; a
// rotor failure (VehicleParams::rotor_failures) is the motor's and scales the speed by
// sqrt(its scale), applied by the callers.
double rotor_speed(const VehicleParams &p, double s, double t);
// The rotor speed in hover (rad/s): speed_max sqrt(m g / (8 k_f)).
double hover_rotor_speed(const VehicleParams &p);

// What bidirectional DShot reports for a rotor at `rpm`: the eRPM period in whole
// microseconds, encoded as a 9-bit mantissa shifted by a 3-bit exponent (so the period's
// step doubles with each exponent), turned back into rpm with the motor's pole pairs.
// 0 for a stopped rotor or a period beyond the encoding (511 << 7 us).
double dshot_rpm(double rpm, double pole_pairs);

// Second-order Butterworth low-pass (bilinear transform, cutoff prewarped),
// transposed direct form II.
struct Biquad {
	double b0 = 1, b1 = 0, b2 = 0, a1 = 0, a2 = 0;
	double z1 = 0, z2 = 0;
	void design(double cutoff_hz, double sample_hz);
	double step(double x)
	{
		const double y = b0 * x + z1;
		z1 = b1 * x - a1 * y + z2;
		z2 = b2 * x - a2 * y;
		return y;
	}
	// |H| at f (Hz) for this design at sample rate fs
	double gain(double f, double fs) const;
};

class Sensors
{
      public:
	// The run's draws (scale errors, constant biases, rotor phases) from (seed, ImuSetup, 0).
	Sensors(const VehicleParams &p, uint64_t seed, double rate);

	// From frame n-1 to frame n (the model now at n / rate): the bias walk takes one step
	// and the vibration path runs over the internal samples of the frame, the rotor speeds
	// interpolated between the two frames.
	void advance(const Model &m, uint64_t n);

	// Stuck rotor-speed reports (VehicleParams::stuck_rpm): called with each frame's reports
	// `rpm` at plant time `clock`, frames in order; a report due to freeze keeps the value it
	// had in the first frame at or after its time.
	void hold_stuck_rpm(double clock, RotorArray &rpm);

	// The IMU's readings in body axes (FLU) before the white noise, for the true specific
	// force (m/s^2) and body rates (rad/s).
	Eigen::Vector3d accel(const Eigen::Vector3d &sf_b) const;
	Eigen::Vector3d gyro(const Eigen::Vector3d &w_b) const;

	// The state (read by the tests).
	Eigen::Vector3d scale_a{0, 0, 0}, scale_g{0, 0, 0}; // scale errors (fractions)
	Eigen::Vector3d bias_a{0, 0, 0}, bias_g{0, 0, 0};   // constant biases
	Eigen::Vector3d walk_a{0, 0, 0}, walk_g{0, 0, 0};   // random walks
	Eigen::Vector3d vib_a{0, 0, 0}, vib_g{0, 0, 0};     // filtered vibration at the read

      private:
	bool vibrates() const;

	VehicleParams p_;
	uint64_t seed_;
	double rate_;
	double hover_speed_;
	RotorArray speed_prev_{}; // rad/s at the previous frame
	double t_prev_ = 0;
	int64_t k_ = 0;                  // index of the last internal sample taken
	double phase_[kRotors] = {};     // rotor angles, rad
	double psi_[kRotors][4][3] = {}; // per rotor and harmonic: phases of x, z (accel) and gyro
	Eigen::Vector3d rock_[kRotors];  // unit axis a rotor's vertical imbalance rocks the body about
	Biquad filt_[6];                 // accel x y z, gyro x y z
	bool stuck_[kRotors] = {};       // rotor j's report is frozen
	double stuck_rpm_[kRotors] = {}; // at this value, rpm
};

} // namespace sim
