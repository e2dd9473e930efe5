// model: eqs (1)-(10) of the paper with Gamma_o's geometry, RK4, ground contact.
#include "model.hpp"

#include <algorithm>
#include <cmath>

namespace sim
{

Model::Model(const VehicleParams &p) : p_(p), delay_(p.delay)
{
	inertia_ = Eigen::Vector3d(p.inertia[0], p.inertia[1], p.inertia[2]);
	for (int j = 0; j < kRotors; j++)
		rotor_pos_[j] = rotor_position(j);
}

Eigen::Vector3d Model::rotor_position(int j) const
{
	// Rotor 1 front, then clockwise seen from above (Z up): angle -j*45 deg.
	// With Y left this gives tau_x = sum y_j f_j, tau_y = -sum x_j f_j, i.e. rows
	// 2 and 3 of Gamma_o in eq. (14). Exact values at multiples of 90 deg.
	static const double c[8] = {1, M_SQRT1_2, 0, -M_SQRT1_2, -1, -M_SQRT1_2, 0, M_SQRT1_2};
	static const double s[8] = {0, -M_SQRT1_2, -1, -M_SQRT1_2, 0, M_SQRT1_2, 1, M_SQRT1_2};
	return Eigen::Vector3d(p_.arm_length * c[j], p_.arm_length * s[j], 0.0);
}

void Model::command(const RotorArray &u)
{
	RotorArray c;
	for (int j = 0; j < kRotors; j++)
		c[j] = std::isfinite(u[j]) ? std::min(1.0, std::max(0.0, u[j])) : 0.0;
	u_cmd_ = c;
	delay_.push(t_, c);
	delay_.apply_due(t_, u_);
	if (p_.motor_tau <= 0)
		x_.s = u_;
}

void Model::set_state(const BodyState &x, double t)
{
	x_ = x;
	t_ = t;
	on_ground_ = false;
	crashed_ = false;
}

double Model::effect(int j, double t) const
{
	double e = p_.rotor_scale[static_cast<size_t>(j)];
	for (const auto &f : p_.rotor_failures)
		if (f.rotor == j && t >= f.at_s - clock0_ - 1e-12)
			e = f.scale;
	return e;
}

RotorOutputs Model::rotor_outputs(const BodyState &x, double t) const
{
	RotorArray eff;
	for (int j = 0; j < kRotors; j++)
		eff[static_cast<size_t>(j)] = effect(j, t);
	return outputs_with(x, t, eff);
}

RotorOutputs Model::outputs_with(const BodyState &x, double t, const RotorArray &eff) const
{
	RotorOutputs o;
	const double d = drift_factor(p_, t);
	for (int j = 0; j < kRotors; j++) {
		const double gj = eff[static_cast<size_t>(j)] * d * thrust_curve(p_.thrust_curve, x.s[j]);
		o.thrust[j] = p_.kf * gj;
		o.torque[j] = yaw_sign(j) * p_.ktau * gj;
		o.force += o.thrust[j];
		// r_j x (0, 0, f_j) = (y_j f_j, -x_j f_j, 0), plus the reaction torque on Z
		o.torque_b.x() += rotor_pos_[j].y() * o.thrust[j];
		o.torque_b.y() -= rotor_pos_[j].x() * o.thrust[j];
		o.torque_b.z() += o.torque[j];
	}
	return o;
}

Model::Vec Model::pack(const BodyState &x)
{
	Vec v;
	v.segment<3>(0) = x.r;
	v.segment<3>(3) = x.v;
	v(6) = x.q.w();
	v(7) = x.q.x();
	v(8) = x.q.y();
	v(9) = x.q.z();
	v.segment<3>(10) = x.w;
	for (int j = 0; j < kRotors; j++)
		v(13 + j) = x.s[j];
	return v;
}

BodyState Model::unpack(const Vec &v)
{
	BodyState x;
	x.r = v.segment<3>(0);
	x.v = v.segment<3>(3);
	x.q = Eigen::Quaterniond(v(6), v(7), v(8), v(9));
	x.w = v.segment<3>(10);
	for (int j = 0; j < kRotors; j++)
		x.s[j] = v(13 + j);
	return x;
}

Model::Vec Model::deriv(double t, const Vec &v) const
{
	const BodyState x = unpack(v);
	const RotorOutputs o = outputs_with(x, t, eff_); // constant over the segment
	const Eigen::Quaterniond qn = x.q.normalized();
	Vec d;
	// eq. (10): r'' = f n / m + [0 0 -g], n = R(q) e_z
	d.segment<3>(0) = x.v;
	d.segment<3>(3) = linear_acceleration(qn, o);
	// eqs. (1)-(4): q' = 1/2 q (x) (0, w)
	const double qw = x.q.w(), qx = x.q.x(), qy = x.q.y(), qz = x.q.z();
	const double wx = x.w.x(), wy = x.w.y(), wz = x.w.z();
	d(6) = 0.5 * (-wx * qx - wy * qy - wz * qz);
	d(7) = 0.5 * (wx * qw + wz * qy - wy * qz);
	d(8) = 0.5 * (wy * qw - wz * qx + wx * qz);
	d(9) = 0.5 * (wz * qw + wy * qx - wx * qy);
	// eqs. (7)-(9)
	const double Ix = inertia_.x(), Iy = inertia_.y(), Iz = inertia_.z();
	d(10) = (Iy - Iz) / Ix * wy * wz + o.torque_b.x() / Ix;
	d(11) = (Iz - Ix) / Iy * wx * wz + o.torque_b.y() / Iy;
	d(12) = (Ix - Iy) / Iz * wx * wy + o.torque_b.z() / Iz;
	// first-order lag s' = (u - s) / tau (none when tau = 0: s follows u)
	for (int j = 0; j < kRotors; j++)
		d(13 + j) = p_.motor_tau > 0 ? (u_[j] - x.s[j]) / p_.motor_tau : 0.0;
	return d;
}

void Model::rotors_only(double h)
{
	if (p_.motor_tau <= 0)
		return;
	const double a = std::exp(-h / p_.motor_tau);
	for (int j = 0; j < kRotors; j++)
		x_.s[j] = u_[j] + (x_.s[j] - u_[j]) * a;
}

void Model::rk4(double h)
{
	const Vec y = pack(x_);
	const Vec k1 = deriv(t_, y);
	const Vec k2 = deriv(t_ + h / 2, y + h / 2 * k1);
	const Vec k3 = deriv(t_ + h / 2, y + h / 2 * k2);
	const Vec k4 = deriv(t_ + h, y + h * k3);
	x_ = unpack(y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4));
	x_.q.normalize();
}

void Model::ground_contact()
{
	if (!ground_enabled_)
		return;
	if (crashed_)
		return;
	if (x_.r.z() > 0) {
		on_ground_ = false;
		return;
	}
	const double up_z = std::max(-1.0, std::min(1.0, (x_.q * Eigen::Vector3d::UnitZ()).z()));
	const double tilt_deg = std::acos(up_z) * 180.0 / M_PI;
	const double speed = std::max(0.0, -x_.v.z());
	if (!on_ground_ && (tilt_deg > kCrashTiltDeg || speed > kCrashSpeed)) {
		// the body stops where and as it hit (arms and propellers in the ground)
		crashed_ = true;
		on_ground_ = true;
		crash_ = CrashInfo{clock(), speed, tilt_deg};
		x_.r.z() = 0;
		x_.v.setZero();
		x_.w.setZero();
		return;
	}
	x_.r.z() = 0;
	if (x_.v.z() < 0)
		x_.v.z() = 0;
	const RotorOutputs o = rotor_outputs(x_, t_);
	const double up = (x_.q * Eigen::Vector3d(0, 0, o.force)).z();
	if (up <= p_.mass * p_.g) {
		// resting on the legs: no motion, level, heading kept
		on_ground_ = true;
		x_.v.setZero();
		x_.w.setZero();
		const Eigen::Matrix3d R = x_.q.toRotationMatrix();
		const double yaw = std::atan2(R(1, 0), R(0, 0));
		x_.q = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
	} else {
		on_ground_ = false;
	}
}

void Model::advance_to(double t1)
{
	while (t_ < t1) {
		delay_.apply_due(t_, u_);
		if (p_.motor_tau <= 0)
			x_.s = u_;
		// a segment ends at the next change of the command or of a rotor's effectiveness
		double seg_end = std::min(t1, delay_.next_after(t_));
		for (const auto &f : p_.rotor_failures)
			if (f.at_s - clock0_ > t_ + 1e-12)
				seg_end = std::min(seg_end, f.at_s - clock0_);
		for (int j = 0; j < kRotors; j++)
			eff_[static_cast<size_t>(j)] = effect(j, t_);
		while (t_ < seg_end) {
			double h = std::min(h_max_, seg_end - t_);
			if (seg_end - t_ - h < 1e-9)
				h = seg_end - t_; // absorb a sliver into this (shortened) last step
			if (crashed_)
				rotors_only(h);
			else
				rk4(h);
			t_ = (seg_end - t_ - h < 1e-9) ? seg_end : t_ + h;
			ground_contact();
		}
	}
	delay_.apply_due(t_, u_);
	if (p_.motor_tau <= 0)
		x_.s = u_;
}

Eigen::Vector3d Model::acceleration() const { return acceleration(rotor_outputs(x_, t_)); }

Eigen::Vector3d Model::acceleration(const RotorOutputs &o) const
{
	if (on_ground_)
		return Eigen::Vector3d::Zero();
	return linear_acceleration(x_.q.normalized(), o);
}

double Model::kinetic_energy_rot() const { return 0.5 * x_.w.dot(inertia_.cwiseProduct(x_.w)); }

} // namespace sim
