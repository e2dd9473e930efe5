// vehicle: the truth the simulator flies (the paper's octocopter by default)
// and its loading from a --vehicle JSON file.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace sim
{

constexpr int kRotors = 8;

struct NoiseParams {
	double thrust = -1.0;       // N, per rotor (row 35); < 0 means "1 % of hover thrust"
	double torque = -1.0;       // N m, per rotor (row 36); < 0 means "1 % of hover torque"
	double gyro = 0.005;        // rad/s, body rates (row 16, Prad/Qrad/Rrad)
	double attitude_deg = 0.02; // deg, row 17 and theta/phi/psi
	double position = 0.005;    // m, rows 20/21 and local_x/y/z
	double accel = 0.004;       // m/s^2, white noise of the specific force per axis (row 4, g_*)
	double rpm = 5.0;           // rpm, each ESC report's noise before quantisation (rows 37/38)
	double current = 0.0;       // A, ESC current-sensor noise, as torque Kt * A (row 36)
};

// IMU bias per axis: a constant drawn once from the seed (sd) plus a random walk
// (sd of its increment over one second; the variance grows linearly with time).
struct ImuBiasParams {
	double accel = 0.05;       // m/s^2, constant bias sd
	double gyro = 0.001;       // rad/s, constant bias sd
	double accel_walk = 0.001; // m/s^2 per sqrt(s)
	double gyro_walk = 1e-4;   // rad/s per sqrt(s)
};

// Rotor imbalance as the IMU sees it: per rotor, a vibration at the rotor speed and
// its harmonics (relative amplitudes), sampled at sample_hz, low-passed (2nd-order
// Butterworth at cutoff_hz) and read at the frame rate.
struct VibrationParams {
	double accel = 0.5; // m/s^2, amplitude per rotor at the hover rotor speed (~ speed^2)
	double gyro = 0.01; // rad/s, amplitude per rotor at the hover rotor speed (~ speed)
	std::array<double, 4> harmonics{{1.0, 0.3, 0.1, 0.0}}; // relative amplitude of 1x..4x
	double cutoff_hz = 30.0;                               // anti-alias low-pass cutoff
	double sample_hz = 1000.0;                             // the IMU's internal sample rate
};

// Which measurements the plant serves (octo-sim --sensors, vehicle key `sensors`).
enum SensorBits : unsigned {
	kSensorImu = 1u,    // rows 4 and 16, g_nrml/g_axil/g_side, Prad/Qrad/Rrad, P/Q/R
	kSensorRpm = 2u,    // rows 37 and 38, POINT_tacrad, ENGN_tacrad
	kSensorTorque = 4u, // row 36, ENGN_TRQ
	kSensorThrust = 8u, // row 35, POINT_thrust
	kSensorAll = 15u,
};
// Parses "imu,rpm,torque,thrust" (any subset, no repeats needed) into bits; false
// with the offending word in `bad` for an unknown one or an empty list.
bool sensors_parse(const std::string &list, unsigned &bits, std::string &bad);

// A rotor that fails in flight (octo-sim --fail-rotor, vehicle key `rotor_failure`): from
// plant time at_s on, rotor `rotor` (0-based) gives `scale` of a nominal rotor's thrust and
// torque, in place of its rotor_scale. The motor loses power, so its speed falls with it:
// to sqrt(scale) of the speed its throttle asks (thrust goes with speed^2).
struct RotorFailure {
	int rotor = 0;    // 0-based
	double at_s = 0;  // plant time, s
	double scale = 0; // remaining effectiveness, [0, 1]
};

// IMU spikes (octo-sim --imu-spike P, vehicle key `imu_spike`): with probability `prob` per
// frame one IMU sample is an outlier: one axis of the gyro or of the accelerometer (drawn
// alike) reads +gyro or -gyro rad/s, or +accel or -accel m/s^2, in place of its value.
struct ImuSpikeParams {
	double prob = 0;     // per frame, [0, 1]
	double gyro = 5.0;   // rad/s, the outlier's magnitude on a gyro axis
	double accel = 50.0; // m/s^2, the outlier's magnitude on an accelerometer axis
};

// A rotor-speed report that freezes (octo-sim --stuck-rpm J@T, vehicle key `stuck_rpm`): from
// the first frame at or after plant time at_s on, rotor `rotor`'s ESC report (rows 37/38)
// repeats the value it had in that frame. The rotor itself is unaffected.
struct StuckRpm {
	int rotor = 0;   // 0-based
	double at_s = 0; // plant time, s
};

struct VehicleParams {
	double mass = 2.132;                                     // kg
	double g = 9.796;                                        // m/s^2
	double arm_length = 0.35;                                // m (the paper gives none: an assumption)
	double kf = 28.0269;                                     // N per unit throttle
	double ktau = 0.3869;                                    // N m per unit throttle
	std::array<double, 3> inertia{{0.0628, 0.0762, 0.1014}}; // kg m^2
	double motor_tau = 0.03;                                 // s, first-order lag; 0 = none
	double delay = 0.0;                                      // s, transport delay of the throttle command
	double thrust_curve = 0.0;                               // c in [0, 1]: g(s) = (1 - c) s + c s^2
	std::array<double, kRotors> rotor_scale{{1, 1, 1, 1, 1, 1, 1, 1}};
	double kf_drift_per_min = 0.0; // fraction per minute (-0.02 = -2 %/min), on kf and ktau
	NoiseParams noise;
	ImuBiasParams imu_bias;
	double imu_scale = 0.005; // sd of each IMU axis's scale-factor error (fraction)
	VibrationParams vibration;
	double rpm_max = 9000.0;         // rotor rpm at full throttle without drift (thrust ~ rpm^2)
	double esc_pole_pairs = 7;       // motor pole pairs: eRPM = pole pairs * rpm (DShot telemetry)
	double esc_kt = 0.013642;        // N m/A, motor torque constant 60 / (2 pi KV), KV 700
	double esc_current_offset = 0.0; // A, each ESC's current reading at zero torque
	double thrust_row_scale = 1.0;   // the thrust rows' gain: a miscalibrated load cell (1: true)
	unsigned sensors = kSensorAll;   // SensorBits served
	std::array<double, 3> origin{{-23.2100, -45.8760, 640.0}}; // lat deg, lon deg, alt m MSL
	// Plant times (s, ascending) at which the OpenGL local origin moves, as X-Plane's
	// scenery shifts do (xplane_emit.hpp: xp_origin_offset).
	std::vector<double> origin_shift_s;
	std::vector<RotorFailure> rotor_failures; // in the order given (the last due one wins)
	ImuSpikeParams imu_spike;                 // IMU outliers (none by default)
	std::vector<StuckRpm> stuck_rpm;          // frozen rotor-speed reports

	// Rotor j's effectiveness at plant time `clock` (rotor_scale, or a failure's scale once
	// it is due), and the failure's factor alone (1 before any failure of rotor j).
	double rotor_effect(int j, double clock) const;
	double failure_factor(int j, double clock) const;

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
