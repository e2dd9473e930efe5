// vehicle: the truth the simulator flies (the paper's octocopter by default)
// and its loading from a --vehicle JSON file.
#pragma once

#include <array>
#include <stdexcept>
#include <string>

namespace sim {

constexpr int kRotors = 8;

struct NoiseParams {
	double thrust = -1.0;       // N, per rotor (row 35); < 0 means "1 % of hover thrust"
	double torque = -1.0;       // N m, per rotor (row 36); < 0 means "1 % of hover torque"
	double gyro = 0.005;        // rad/s, body rates (row 16, Prad/Qrad/Rrad)
	double attitude_deg = 0.02; // deg, row 17 and theta/phi/psi
	double position = 0.005;    // m, rows 20/21 and local_x/y/z
};

struct VehicleParams {
	double mass = 2.132;        // kg
	double g = 9.796;           // m/s^2
	double arm_length = 0.35;   // m (the paper gives none: an assumption)
	double kf = 28.0269;        // N per unit throttle
	double ktau = 0.3869;       // N m per unit throttle
	std::array<double, 3> inertia{{0.0628, 0.0762, 0.1014}}; // kg m^2
	double motor_tau = 0.03;    // s, first-order lag; 0 = none
	double delay = 0.0;         // s, transport delay of the throttle command
	double thrust_curve = 0.0;  // c in [0, 1]: g(s) = (1 - c) s + c s^2
	std::array<double, kRotors> rotor_scale{{1, 1, 1, 1, 1, 1, 1, 1}};
	double kf_drift_per_min = 0.0; // fraction per minute (-0.02 = -2 %/min), on kf and ktau
	NoiseParams noise;
	std::array<double, 3> origin{{-23.2100, -45.8760, 640.0}}; // lat deg, lon deg, alt m MSL

	double hover_throttle() const { return mass * g / (kRotors * kf); }
	// Resolved noise sigmas (defaults relative to hover).
	double sigma_thrust() const { return noise.thrust >= 0 ? noise.thrust : 0.01 * mass * g / kRotors; }
	double sigma_torque() const { return noise.torque >= 0 ? noise.torque : 0.01 * ktau * hover_throttle(); }
	// --ideal: no noise, no lag, no delay.
	void make_ideal();
};

struct VehicleError : std::runtime_error {
	std::string key; // the offending key ("" for a syntax error)
	VehicleError(const std::string &k, const std::string &what) : std::runtime_error(what), key(k) {}
};

// Applies the keys of a JSON text to p (absent keys keep their value).
// Throws VehicleError naming the key on an unknown key or an impossible value.
void vehicle_from_json(const std::string &text, VehicleParams &p);
// Reads a file and applies it; also VehicleError when unreadable.
void vehicle_load(const std::string &path, VehicleParams &p);

} // namespace sim
