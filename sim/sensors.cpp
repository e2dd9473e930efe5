// sensors: IMU and ESC models (see sensors.hpp and docs/sensors.md).
#include "sensors.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

#include "rng.hpp"

namespace sim
{

namespace
{

constexpr double kRadPerRpm = 2.0 * M_PI / 60.0;
constexpr int kHarm = 4;

} // namespace

double rotor_speed(const VehicleParams &p, double s, double t)
{
	const double g = drift_factor(p, t) * thrust_curve(p.thrust_curve, s);
	return p.rpm_max * kRadPerRpm * std::sqrt(g > 0 ? g : 0.0);
}

double hover_rotor_speed(const VehicleParams &p) { return p.rpm_max * kRadPerRpm * std::sqrt(p.hover_throttle()); }

double dshot_rpm(double rpm, double pole_pairs)
{
	if (!(rpm > 0) || !(pole_pairs > 0))
		return 0.0;
	const double period = 60e6 / (rpm * pole_pairs); // eRPM period, us
	if (period >= 65536.0)
		return 0.0;
	long us = std::lround(period);
	int e = 0;
	while ((us >> e) > 511)
		e++;
	long m = (us + ((1L << e) >> 1)) >> e; // rounded to the exponent's step
	if (m > 511) {
		e++;
		m = (us + ((1L << e) >> 1)) >> e;
	}
	if (e > 7 || m == 0)
		return 0.0;
	return 60e6 / (static_cast<double>(m << e) * pole_pairs);
}

void Biquad::design(double cutoff_hz, double sample_hz)
{
	const double k = std::tan(M_PI * cutoff_hz / sample_hz);
	const double q = M_SQRT1_2;
	const double n = 1.0 / (1.0 + k / q + k * k);
	b0 = k * k * n;
	b1 = 2 * b0;
	b2 = b0;
	a1 = 2 * (k * k - 1) * n;
	a2 = (1 - k / q + k * k) * n;
	z1 = z2 = 0;
}

double Biquad::gain(double f, double fs) const
{
	const double w = 2 * M_PI * f / fs;
	const std::complex<double> z1c = std::polar(1.0, -w), z2c = std::polar(1.0, -2 * w);
	return std::abs((b0 + b1 * z1c + b2 * z2c) / (1.0 + a1 * z1c + a2 * z2c));
}

Sensors::Sensors(const VehicleParams &p, uint64_t seed, double rate)
    : p_(p), seed_(seed), rate_(rate), hover_speed_(hover_rotor_speed(p))
{
	Rng r(seed, Stream::ImuSetup, 0);
	for (int i = 0; i < 3; i++)
		scale_a[i] = p.imu_scale * r.gauss();
	for (int i = 0; i < 3; i++)
		scale_g[i] = p.imu_scale * r.gauss();
	for (int i = 0; i < 3; i++)
		bias_a[i] = p.imu_bias.accel * r.gauss();
	for (int i = 0; i < 3; i++)
		bias_g[i] = p.imu_bias.gyro * r.gauss();
	for (int j = 0; j < kRotors; j++) {
		phase_[j] = 2 * M_PI * r.uniform();
		for (int h = 0; h < kHarm; h++)
			for (int c = 0; c < 3; c++)
				psi_[j][h][c] = 2 * M_PI * r.uniform();
		// a vertical force at the rotor (x_j, y_j) rocks the body about (y_j, -x_j, 0)
		const double a = -j * M_PI / 4;
		rock_[j] = Eigen::Vector3d(std::sin(a), -std::cos(a), 0.0);
	}
	for (auto &f : filt_)
		f.design(p.vibration.cutoff_hz, p.vibration.sample_hz);
	t_prev_ = 0;
}

bool Sensors::vibrates() const { return (p_.vibration.accel > 0 || p_.vibration.gyro > 0) && hover_speed_ > 0; }

void Sensors::advance(const Model &m, uint64_t n)
{
	const double t1 = static_cast<double>(n) / rate_;
	// bias random walk: one step of sd * sqrt(dt) per axis
	const double dt = t1 - t_prev_;
	if (dt > 0) {
		Rng r(seed_, Stream::ImuWalk, n);
		const double sa = p_.imu_bias.accel_walk * std::sqrt(dt), sg = p_.imu_bias.gyro_walk * std::sqrt(dt);
		for (int i = 0; i < 3; i++)
			walk_a[i] += sa * r.gauss();
		for (int i = 0; i < 3; i++)
			walk_g[i] += sg * r.gauss();
	}
	RotorArray speed;
	for (int j = 0; j < kRotors; j++)
		speed[static_cast<size_t>(j)] = rotor_speed(p_, m.state().s[static_cast<size_t>(j)], m.t()) *
						std::sqrt(p_.failure_factor(j, m.clock()));
	if (vibrates() && dt > 0) {
		const double fs = p_.vibration.sample_hz, ts = 1.0 / fs;
		const int64_t k1 = static_cast<int64_t>(std::floor(t1 * fs + 1e-9));
		double y[6] = {vib_a.x(), vib_a.y(), vib_a.z(), vib_g.x(), vib_g.y(), vib_g.z()};
		for (int64_t k = k_ + 1; k <= k1; k++) {
			const double tk = static_cast<double>(k) * ts;
			const double w = std::min(1.0, std::max(0.0, (tk - t_prev_) / dt));
			double in[6] = {0, 0, 0, 0, 0, 0};
			for (int j = 0; j < kRotors; j++) {
				const size_t ju = static_cast<size_t>(j);
				const double om = speed_prev_[ju] + w * (speed[ju] - speed_prev_[ju]);
				phase_[j] = std::fmod(phase_[j] + om * ts, 2 * M_PI);
				if (om <= 0)
					continue;
				const double ra = om / hover_speed_;
				const double aa = p_.vibration.accel * ra * ra, ag = p_.vibration.gyro * ra;
				const double dir = Model::yaw_sign(j);
				for (int h = 0; h < kHarm; h++) {
					const double rel = p_.vibration.harmonics[static_cast<size_t>(h)];
					if (rel == 0)
						continue;
					const double th = (h + 1) * phase_[j] + psi_[j][h][0];
					// in the rotor's plane the imbalance force turns with the rotor;
					// half of it out of the plane (blade track, arm flex)
					in[0] += aa * rel * std::cos(th);
					in[1] += aa * rel * dir * std::sin(th);
					in[2] += 0.5 * aa * rel * std::cos(th + psi_[j][h][1]);
					const double gr = ag * rel * std::cos(th + psi_[j][h][2]);
					in[3] += gr * rock_[j].x();
					in[4] += gr * rock_[j].y();
				}
			}
			for (int c = 0; c < 6; c++)
				y[c] = filt_[c].step(in[c]);
		}
		if (k1 > k_)
			k_ = k1;
		vib_a = Eigen::Vector3d(y[0], y[1], y[2]);
		vib_g = Eigen::Vector3d(y[3], y[4], y[5]);
	}
	speed_prev_ = speed;
	t_prev_ = t1;
}

void Sensors::hold_stuck_rpm(double clock, RotorArray &rpm)
{
	for (const auto &st : p_.stuck_rpm) {
		if (clock < st.at_s)
			continue;
		const size_t j = static_cast<size_t>(st.rotor);
		if (!stuck_[j]) {
			stuck_[j] = true;
			stuck_rpm_[j] = rpm[j];
		}
		rpm[j] = stuck_rpm_[j];
	}
}

Eigen::Vector3d Sensors::accel(const Eigen::Vector3d &sf_b) const
{
	return sf_b + scale_a.cwiseProduct(sf_b) + bias_a + walk_a + vib_a;
}

Eigen::Vector3d Sensors::gyro(const Eigen::Vector3d &w_b) const
{
	return w_b + scale_g.cwiseProduct(w_b) + bias_g + walk_g + vib_g;
}

} // namespace sim
