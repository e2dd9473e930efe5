// model: the paper's octocopter, eqs (1)-(10), in the paper's frames
// (S_I: Z up; S_B: X forward, Y left, Z up), rotor geometry of Gamma_o (eq. 14),
// the actuator lag as part of the state, RK4 with steps of at most h_max, and
// ground contact (the vehicle starts landed at the origin, never sinks below; a contact
// tilted beyond kCrashTiltDeg or faster than kCrashSpeed is a crash: the vehicle stays
// where and as it hit, whatever the rotors do).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "actuator.hpp"
#include "vehicle.hpp"

namespace sim
{

struct BodyState {
	Eigen::Vector3d r{0, 0, 0};       // position in S_I, m
	Eigen::Vector3d v{0, 0, 0};       // velocity in S_I, m/s
	Eigen::Quaterniond q{1, 0, 0, 0}; // v_I = q v_B q* (scalar first, eq. 1)
	Eigen::Vector3d w{0, 0, 0};       // angular velocity in S_B, rad/s
	RotorArray s{};                   // actuator outputs s_j (after lag)
};

// Forces and torques for a state (what the rotors do now).
struct RotorOutputs {
	RotorArray thrust{}; // f_j, N
	RotorArray torque{}; // signed reaction torque about +Z_B, N m
	double force = 0;    // sum f_j, N
	Eigen::Vector3d torque_b{0, 0, 0};
};

// A touch-down the legs cannot take: tilt of the body's Z axis from the vertical, and
// speed towards the ground, at the contact (a fall from about 5 m reaches 10 m/s).
constexpr double kCrashTiltDeg = 60.0;
constexpr double kCrashSpeed = 10.0;

struct CrashInfo {
	double t = 0;        // the plant's clock at the contact, s
	double speed = 0;    // speed towards the ground, m/s
	double tilt_deg = 0; // tilt from the vertical, deg
};

class Model
{
      public:
	explicit Model(const VehicleParams &p);

	// Rotor j (0-based) position in S_B: angle -j * 45 deg from +X_B, radius l.
	Eigen::Vector3d rotor_position(int j) const;
	// Yaw sign of rotor j (0-based): +1 for rotors 1, 3, 5, 7 (odd 1-based), -1 otherwise.
	static double yaw_sign(int j) { return (j % 2 == 0) ? 1.0 : -1.0; }

	// Throttle command at the current time t (0..1 each); takes effect after the delay.
	void command(const RotorArray &u);
	// Integrates to t1 (> t) with RK4 steps of at most h_max; the step is cut at
	// every change of the delayed command and the last step is shortened to end
	// exactly at t1.
	void advance_to(double t1);

	// Time since the start of the simulation, s: the model's own time, integrated from 0.
	double t() const { return t_; }
	// The plant's clock, s: the start (octo-sim --start-time) plus t(). What the plant
	// shows as time (Data Output row 1, the time datarefs, the truth log); the dynamics
	// run on t() alone, so a run started at S integrates exactly as one started at 0.
	double clock() const { return clock0_ + t_; }
	void set_clock_start(double s) { clock0_ = s; }
	const BodyState &state() const { return x_; }
	void set_state(const BodyState &x, double t);
	bool on_ground() const { return on_ground_; }
	// true from a crash on (see kCrashTiltDeg): the body no longer moves; the rotors'
	// states still follow their commands (measured thrust keeps its meaning).
	bool crashed() const { return crashed_; }
	const CrashInfo &crash() const { return crash_; }
	const RotorArray &command_in_force() const { return u_; }
	const RotorArray &last_command() const { return u_cmd_; }
	const VehicleParams &params() const { return p_; }
	double h_max() const { return h_max_; }
	void set_h_max(double h) { h_max_ = h; }
	void set_ground(bool enabled) { ground_enabled_ = enabled; }

	RotorOutputs rotor_outputs(const BodyState &x, double t) const;
	// Rotor j's effectiveness at model time t: rotor_scale, or a failure's scale from its
	// time on (VehicleParams::rotor_failures, in plant time).
	double effect(int j, double t) const;
	// Acceleration in S_I at the current state (0 while resting on the ground).
	Eigen::Vector3d acceleration() const;
	// The same from this state's rotor outputs (rotor_outputs(state(), t())).
	Eigen::Vector3d acceleration(const RotorOutputs &o) const;
	double kinetic_energy_rot() const;

      private:
	using Vec = Eigen::Matrix<double, 21, 1>;
	static Vec pack(const BodyState &x);
	static BodyState unpack(const Vec &v);
	Vec deriv(double t, const Vec &v) const;
	RotorOutputs outputs_with(const BodyState &x, double t, const RotorArray &eff) const;
	// eq. (10): r'' = f n / m + [0 0 -g] for the normalised attitude qn (in the class:
	// inlined into the integrator's derivative)
	Eigen::Vector3d linear_acceleration(const Eigen::Quaterniond &qn, const RotorOutputs &o) const
	{
		return qn * Eigen::Vector3d(0, 0, o.force / p_.mass) - Eigen::Vector3d(0, 0, p_.g);
	}
	void rk4(double h);
	// after a crash: only the rotors' lags advance, exactly
	void rotors_only(double h);
	void ground_contact();

	VehicleParams p_;
	Eigen::Vector3d inertia_;
	Eigen::Vector3d rotor_pos_[kRotors];
	BodyState x_;
	double t_ = 0;
	double h_max_ = 0.002;
	double clock0_ = 0;
	bool on_ground_ = true;
	bool ground_enabled_ = true;
	bool crashed_ = false;
	CrashInfo crash_;
	DelayLine delay_;
	RotorArray u_{};     // command in force (after the delay)
	RotorArray u_cmd_{}; // last command given
	RotorArray eff_{};   // effectiveness over the segment being integrated (advance_to)
};

} // namespace sim
