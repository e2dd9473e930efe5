// Unit tests of octo-sim's model, actuator, JSON reader and byte encoders.
// Run by `make test-sim` and by tests/py/test_sim_model.py; exit status 0 when
// every test passes. Physics checks use the model class directly (no sockets).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "actuator.hpp"
#include "json.hpp"
#include "model.hpp"
#include "options.hpp"
#include "vehicle.hpp"
#include "rng.hpp"
#include "sensors.hpp"
#include "xplane_emit.hpp"
#include "xplane_input.hpp"
#include "xplane_proto.hpp"

using namespace sim;

static int g_failed = 0, g_checks = 0;
static const char *g_test = "";

#define CHECK(cond, ...)                                                                         \
	do {                                                                                     \
		g_checks++;                                                                      \
		if (!(cond)) {                                                                   \
			g_failed++;                                                              \
			std::printf("FAIL %s (%s:%d): %s: ", g_test, __FILE__, __LINE__, #cond); \
			std::printf(__VA_ARGS__);                                                \
			std::printf("\n");                                                       \
		}                                                                                \
	} while (0)

struct TestCase {
	const char *name;
	std::function<void()> fn;
};
static std::vector<TestCase> &registry()
{
	static std::vector<TestCase> r;
	return r;
}
struct Reg {
	Reg(const char *n, std::function<void()> f) { registry().push_back({n, f}); }
};
#define TEST(name)                          \
	static void name();                 \
	static Reg reg_##name(#name, name); \
	static void name()

static VehicleParams ideal()
{
	VehicleParams p;
	p.make_ideal();
	return p;
}

static RotorArray all(double v)
{
	RotorArray u;
	u.fill(v);
	return u;
}

static std::string hex(const xp::Bytes &b)
{
	std::string s;
	char t[3];
	for (uint8_t c : b) {
		std::snprintf(t, sizeof t, "%02x", c);
		s += t;
	}
	return s;
}

// ------------------------------------------------------------------ physics

TEST(hover_holds_altitude_1mm_10s)
{
	VehicleParams p = ideal();
	Model m(p);
	BodyState x;
	x.r.z() = 10.0;
	m.set_state(x, 0.0);
	m.command(all(p.mass * p.g / (8 * p.kf)));
	double worst = 0;
	for (int n = 1; n <= 900; n++) {
		m.advance_to(n / 90.0);
		worst = std::max(worst, std::fabs(m.state().r.z() - 10.0));
	}
	std::printf("  hover: worst altitude error over 10 s %.3g m\n", worst);
	CHECK(worst < 1e-3, "worst altitude error %g m", worst);
	CHECK(std::fabs(m.t() - 10.0) < 1e-12, "t = %.15g", m.t());
	CHECK(m.state().w.norm() < 1e-12, "rates %g", m.state().w.norm());
}

TEST(hover_from_ground_stays_landed_below_weight)
{
	VehicleParams p = ideal();
	Model m(p);
	m.command(all(0.5 * p.hover_throttle()));
	m.advance_to(2.0);
	CHECK(m.on_ground(), "should rest on the ground");
	CHECK(m.state().r.z() == 0.0, "z = %g", m.state().r.z());
	m.command(all(1.2 * p.hover_throttle()));
	m.advance_to(3.0);
	CHECK(!m.on_ground() && m.state().r.z() > 0.1, "should climb: z = %g", m.state().r.z());
}

TEST(free_fall_matches_half_g_t2)
{
	VehicleParams p = ideal();
	Model m(p);
	BodyState x;
	x.r.z() = 100.0;
	m.set_state(x, 0.0);
	m.command(all(0.0));
	double worst = 0;
	for (int n = 1; n <= 270; n++) { // 3 s
		m.advance_to(n / 90.0);
		const double t = m.t();
		worst = std::max(worst, std::fabs(m.state().r.z() - (100.0 - 0.5 * p.g * t * t)));
	}
	std::printf("  free fall: worst error over 3 s %.3g m\n", worst);
	CHECK(worst < 1e-9, "free-fall error %g m", worst);
	// and the ground stops it
	m.advance_to(10.0);
	CHECK(m.state().r.z() == 0.0 && m.on_ground(), "z = %g", m.state().r.z());
}

// A contact the legs cannot take stops the body where and as it hit, whatever the rotors
// do after; a gentle one lands level (hover_from_ground_stays_landed_below_weight).
TEST(crash_tilted_or_fast_contact_stays_down)
{
	VehicleParams p = ideal();
	const struct {
		double tilt_deg, vz;
		bool crash;
	} cases[] = {
		{80.0, -1.0, true}, {65.0, -0.5, true}, {30.0, -1.0, false}, {0.0, -12.0, true}, {0.0, -3.0, false}};
	for (const auto &c : cases) {
		Model m(p);
		BodyState x;
		x.r.z() = 0.05;
		x.v.z() = c.vz;
		x.q = Eigen::Quaterniond(Eigen::AngleAxisd(c.tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()));
		m.set_state(x, 0.0);
		m.command(all(0.0));
		m.advance_to(0.2);
		CHECK(m.on_ground() && m.state().r.z() == 0.0, "tilt %g vz %g: z = %g", c.tilt_deg, c.vz,
		      m.state().r.z());
		CHECK(m.crashed() == c.crash, "tilt %g vz %g: crashed %d", c.tilt_deg, c.vz, m.crashed());
		if (!c.crash)
			continue;
		CHECK(std::fabs(m.crash().tilt_deg - c.tilt_deg) < 1.0 && m.crash().t < 0.2, "crash tilt %g at %g s",
		      m.crash().tilt_deg, m.crash().t);
		// full throttle: the body stays (tipped as it hit), the rotors still spin up
		const Eigen::Quaterniond q = m.state().q;
		m.command(all(1.0));
		m.advance_to(2.0);
		CHECK(m.state().r.norm() < 1e-12 && m.state().v.norm() == 0.0 && m.state().q.isApprox(q),
		      "moved after the crash: z %g", m.state().r.z());
		CHECK(m.acceleration().norm() == 0.0, "acceleration after a crash");
		CHECK(m.state().s[0] > 0.99, "rotor state %g", m.state().s[0]);
		const XpFrame f = xp_measure(m, all(1.0), 1, 180);
		float v = -1;
		std::array<float, 16> th{};
		CHECK(xp_dataref(f, "sim/flightmodel2/misc/has_crashed", 12, true, th, th, v) && v == 1.0f,
		      "has_crashed %g", v);
	}
}

TEST(torque_free_tumble_conserves_momentum_and_energy)
{
	VehicleParams p = ideal();
	Model m(p);
	m.set_ground(false);
	BodyState x;
	x.r.z() = 1000;
	x.w = Eigen::Vector3d(0.6, -0.4, 0.9);
	m.set_state(x, 0.0);
	m.command(all(0.0));
	const Eigen::Vector3d I(p.inertia[0], p.inertia[1], p.inertia[2]);
	auto h_inertial = [&]() { return Eigen::Vector3d(m.state().q * I.cwiseProduct(m.state().w)); };
	const Eigen::Vector3d h0 = h_inertial();
	const double e0 = m.kinetic_energy_rot();
	double worst_h = 0, worst_e = 0;
	for (int n = 1; n <= 900; n++) {
		m.advance_to(n / 90.0);
		worst_h = std::max(worst_h, (h_inertial() - h0).norm() / h0.norm());
		worst_e = std::max(worst_e, std::fabs(m.kinetic_energy_rot() - e0) / e0);
	}
	std::printf("  tumble: relative error momentum %.3g, energy %.3g\n", worst_h, worst_e);
	CHECK(worst_h < 1e-9, "angular momentum relative error %g", worst_h);
	CHECK(worst_e < 1e-9, "kinetic energy relative error %g", worst_e);
	CHECK((m.state().w - x.w).norm() > 0.1, "the body should actually tumble");
}

// A nonlinear manoeuvre (rotors uneven, lag on) integrated with steps h, h/2 and a
// fine reference: RK4's error ratio must be about 2^4 = 16.
TEST(rk4_order_error_ratio_16)
{
	VehicleParams p = ideal();
	p.motor_tau = 0.05;
	auto run = [&](double h) {
		Model m(p);
		m.set_ground(false);
		m.set_h_max(h);
		BodyState x;
		x.r.z() = 50;
		x.w = Eigen::Vector3d(1.0, -0.5, 0.7);
		m.set_state(x, 0.0);
		RotorArray u{{0.2, 0.05, 0.15, 0.08, 0.12, 0.1, 0.02, 0.18}};
		m.command(u);
		m.advance_to(2.0);
		Eigen::Matrix<double, 13, 1> v;
		v << m.state().r, m.state().v, m.state().q.w(), m.state().q.x(), m.state().q.y(), m.state().q.z(),
			m.state().w;
		return v;
	};
	const auto ref = run(0.02 / 64);
	const double e1 = (run(0.02) - ref).norm();
	const double e2 = (run(0.01) - ref).norm();
	const double ratio = e1 / e2;
	std::printf("  rk4: error(h=20ms) %.3g, error(h=10ms) %.3g, ratio %.2f\n", e1, e2, ratio);
	CHECK(ratio > 13 && ratio < 19, "ratio %g", ratio);
}

// Gamma_o of eq. (14): [f; tau] = Gamma_o f for any rotor forces.
TEST(geometry_matches_gamma_o)
{
	VehicleParams p = ideal();
	Model m(p);
	const double l = p.arm_length, r2 = std::sqrt(2.0) / 2 * l, k = p.ktau / p.kf;
	const double G[4][8] = {
		{1, 1, 1, 1, 1, 1, 1, 1},
		{0, -r2, -l, -r2, 0, r2, l, r2},
		{-l, -r2, 0, r2, l, r2, 0, -r2},
		{k, -k, k, -k, k, -k, k, -k},
	};
	BodyState x;
	RotorArray s{{0.11, 0.32, 0.05, 0.27, 0.19, 0.08, 0.41, 0.14}};
	x.s = s;
	RotorOutputs o = m.rotor_outputs(x, 0.0);
	double want[4] = {0, 0, 0, 0};
	for (int i = 0; i < 4; i++)
		for (int j = 0; j < 8; j++)
			want[i] += G[i][j] * p.kf * s[j];
	CHECK(std::fabs(o.force - want[0]) < 1e-12, "f %g vs %g", o.force, want[0]);
	for (int i = 0; i < 3; i++)
		CHECK(std::fabs(o.torque_b(i) - want[i + 1]) < 1e-12, "tau[%d] %g vs %g", i, o.torque_b(i),
		      want[i + 1]);
}

// ------------------------------------------------------------------ actuator

TEST(lag_reaches_63_percent_at_tau)
{
	VehicleParams p = ideal();
	p.motor_tau = 0.03;
	Model m(p);
	m.command(all(0.5));
	m.advance_to(0.03);
	CHECK(std::fabs(m.state().s[0] - 0.5 * (1 - std::exp(-1.0))) < 1e-7, "s = %.9f", m.state().s[0]);
}

TEST(transport_delay_shifts_the_step)
{
	VehicleParams p = ideal();
	p.delay = 0.005;
	Model m(p);
	m.command(all(0.3));
	m.advance_to(0.004);
	CHECK(m.state().s[2] == 0.0, "before the delay s = %g", m.state().s[2]);
	m.advance_to(0.006);
	CHECK(m.state().s[2] == 0.3, "after the delay s = %g", m.state().s[2]);
}

TEST(rotor_scale_curve_and_drift)
{
	VehicleParams p = ideal();
	p.rotor_scale[3] = 0.5;
	p.thrust_curve = 0.4;
	p.kf_drift_per_min = -0.06;
	Model m(p);
	BodyState x;
	x.s = all(0.5);
	RotorOutputs o = m.rotor_outputs(x, 30.0); // half a minute: factor 0.97
	const double g = 0.6 * 0.5 + 0.4 * 0.25;
	CHECK(std::fabs(o.thrust[0] - p.kf * 0.97 * g) < 1e-12, "thrust %g", o.thrust[0]);
	CHECK(std::fabs(o.thrust[3] - 0.5 * p.kf * 0.97 * g) < 1e-12, "thrust %g", o.thrust[3]);
	CHECK(std::fabs(o.torque[1] + p.ktau * 0.97 * g) < 1e-12, "torque %g", o.torque[1]);
}

// A rotor failure: from its plant time on, the rotor gives S of its thrust and torque (the
// others unchanged), its speed falls to sqrt(S); the integration step is cut at the time.
TEST(rotor_failure_cuts_thrust_torque_and_speed)
{
	VehicleParams p = ideal();
	p.rotor_failures.push_back(RotorFailure{2, 0.5, 0.25});
	Model m(p);
	m.set_clock_start(0.25); // the failure is due at plant time 0.5: model time 0.25
	BodyState x;
	x.r.z() = 10.0;
	x.s = all(0.3);
	m.set_state(x, 0.0);
	m.command(all(0.3));
	RotorOutputs o0 = m.rotor_outputs(m.state(), 0.2);
	RotorOutputs o1 = m.rotor_outputs(m.state(), 0.3);
	CHECK(std::fabs(o0.thrust[2] - p.kf * 0.3) < 1e-12, "before: %g", o0.thrust[2]);
	CHECK(std::fabs(o1.thrust[2] - 0.25 * p.kf * 0.3) < 1e-12, "after: %g", o1.thrust[2]);
	CHECK(std::fabs(o1.torque[2] - 0.25 * p.ktau * 0.3) < 1e-12, "torque after: %g", o1.torque[2]);
	CHECK(o1.thrust[1] == o0.thrust[1] && o1.thrust[3] == o0.thrust[3], "others unchanged");
	CHECK(p.failure_factor(2, 0.49) == 1.0 && p.failure_factor(2, 0.5) == 0.25 && p.failure_factor(1, 9) == 1.0,
	      "factor");
	// exact integration across the failure: a roll torque appears at model time 0.25 exactly
	m.set_h_max(0.1);
	m.advance_to(0.25);
	CHECK(m.state().w.norm() < 1e-12, "no rate before the failure: %g", m.state().w.norm());
	m.advance_to(0.3);
	CHECK(m.state().w.norm() > 1e-3, "a rate after it: %g", m.state().w.norm());
	// the measured speed and the truth's scale
	XpFrame f = xp_measure(m, all(0.3), 1, 1);
	CHECK(std::fabs(f.rpm_true[2] / f.rpm_true[0] - 0.5) < 1e-9, "speed ratio %g", f.rpm_true[2] / f.rpm_true[0]);
	CHECK(p.rotor_effect(2, 0.6) == 0.25 && p.rotor_effect(0, 0.6) == 1.0, "effect");
}

// --fail-rotor J@T[:S] and the vehicle key rotor_failure (one object or a list); bad values
// are refused (exit 2).
TEST(fail_rotor_flag_and_key)
{
	auto parse = [](std::vector<std::string> args, Options &o) {
		std::vector<char *> argv;
		static char prog[] = "octo-sim";
		argv.push_back(prog);
		for (auto &a : args)
			argv.push_back(&a[0]);
		return parse_options(static_cast<int>(argv.size()), argv.data(), o);
	};
	Options o;
	CHECK(parse({"--fail-rotor", "3@12.5", "--fail-rotor", "8@20:0.4"}, o) == -1, "parsed");
	const auto &f = o.vehicle.rotor_failures;
	CHECK(f.size() == 2 && f[0].rotor == 2 && f[0].at_s == 12.5 && f[0].scale == 0 && f[1].rotor == 7 &&
		      f[1].at_s == 20 && f[1].scale == 0.4,
	      "values");
	for (const char *bad : {"0@1", "9@1", "x@1", "3", "3@", "3@-1", "3@1:1.5", "3@1:-0.1", "3@1:", "3@nan"}) {
		Options q;
		std::fprintf(stderr, "  (expected) ");
		CHECK(parse({"--fail-rotor", bad}, q) == 2, "%s accepted", bad);
	}
	VehicleParams p;
	vehicle_from_json(R"({"rotor_failure": {"rotor": 4, "at_s": 3, "scale": 0.2}})", p);
	CHECK(p.rotor_failures.size() == 1 && p.rotor_failures[0].rotor == 3 && p.rotor_failures[0].scale == 0.2,
	      "key");
	vehicle_from_json(R"({"rotor_failure": [{"rotor": 1, "at_s": 3}, {"rotor": 2, "at_s": 4, "scale": 1}]})", p);
	CHECK(p.rotor_failures.size() == 2 && p.rotor_failures[0].scale == 0 && p.rotor_failures[1].rotor == 1, "list");
	for (const char *bad :
	     {R"({"rotor_failure": {"rotor": 9, "at_s": 1}})", R"({"rotor_failure": {"rotor": 1.5, "at_s": 1}})",
	      R"({"rotor_failure": {"at_s": 1}})", R"({"rotor_failure": {"rotor": 1}})",
	      R"({"rotor_failure": {"rotor": 1, "at_s": 1, "scale": 2}})",
	      R"({"rotor_failure": {"rotor": 1, "at_s": 1, "x": 2}})", R"({"rotor_failure": 3})"}) {
		std::string key;
		try {
			VehicleParams q;
			vehicle_from_json(bad, q);
		} catch (const VehicleError &e) {
			key = e.key;
		}
		CHECK(key.rfind("rotor_failure", 0) == 0, "%s: key '%s'", bad, key.c_str());
	}
}

TEST(command_clamps_and_rejects_nan)
{
	VehicleParams p = ideal();
	Model m(p);
	RotorArray u{{-1, 2, NAN, 0.5, INFINITY, 0, 1, 0.25}};
	m.command(u);
	const RotorArray &c = m.last_command();
	CHECK(c[0] == 0 && c[1] == 1 && c[2] == 0 && c[3] == 0.5 && c[4] == 0 && c[7] == 0.25, "clamped");
}

// ------------------------------------------------------------------ X-Plane frames

TEST(emitter_conventions)
{
	VehicleParams p = ideal();
	Model m(p);
	BodyState x;
	x.r = Eigen::Vector3d(3, 4, 5); // 3 m north, 4 m west, 5 m up
	x.v = Eigen::Vector3d(1, 2, 3);
	x.w = Eigen::Vector3d(0.1, 0.2, 0.3);
	// paper yaw +30 deg (counter-clockwise from above) -> heading 330
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(30 * M_PI / 180, Eigen::Vector3d::UnitZ()));
	m.set_state(x, 0.0);
	XpFrame f = xp_measure(m, all(0), 1, 0);
	CHECK(std::fabs(f.heading - 330) < 1e-9, "heading %g", f.heading);
	CHECK(std::fabs(f.P - 0.1) < 1e-12 && std::fabs(f.Q + 0.2) < 1e-12 && std::fabs(f.R + 0.3) < 1e-12, "PQR");
	xp::DataRow r21 = xp_row(f, 21, 12);
	// OpenGL's origin is at sea level: y is the field's elevation plus the height
	const float y21 = static_cast<float>(m.params().origin[2] + 5.0);
	CHECK(r21.col[0] == -4.0f && r21.col[1] == y21 && r21.col[2] == -3.0f, "local xyz %g %g %g", r21.col[0],
	      r21.col[1], r21.col[2]);
	CHECK(r21.col[3] == -2.0f && r21.col[4] == 3.0f && r21.col[5] == -1.0f, "local v");
	xp::DataRow r16_12 = xp_row(f, 16, 12), r16_11 = xp_row(f, 16, 11);
	CHECK(std::fabs(r16_12.col[0] - 0.1 * 180 / M_PI) < 1e-4, "v12 c1 = P deg/s");
	CHECK(r16_11.col[0] == -0.2f && r16_11.col[1] == 0.1f && r16_11.col[2] == -0.3f, "v11 Q P R rad/s");
	CHECK(r16_12.col[3] == xp::kNoData && r16_12.col[7] == xp::kNoData, "unused columns -999");
	// roll right (paper: negative rotation about X_B... i.e. positive about forward in FRD)
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()));
	m.set_state(x, 0.0);
	f = xp_measure(m, all(0), 1, 0);
	CHECK(f.roll < -11 && f.roll > -12, "a left-side-down FLU rotation is a negative roll: %g", f.roll);
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()));
	m.set_state(x, 0.0);
	f = xp_measure(m, all(0), 1, 0);
	CHECK(f.pitch > 11 && f.pitch < 12, "a negative rotation about Y_B (left) is nose up: %g", f.pitch);
	// X-Plane q from the half angles equals the rotation NED <- FRD
	double q[4];
	xp_frame_quat(f, q);
	const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	CHECK(std::fabs(n - 1) < 1e-12, "|q| = %g", n);
	CHECK(std::fabs(q[2] - std::sin(0.1)) < 1e-12, "q.y = %g", q[2]);
}

TEST(noise_depends_on_seed_and_frame_only)
{
	VehicleParams p; // default noise
	Model m(p);
	XpFrame a = xp_measure(m, all(0), 7, 3), b = xp_measure(m, all(0), 7, 3), c = xp_measure(m, all(0), 8, 3);
	CHECK(a.P == b.P && a.thrust_n[5] == b.thrust_n[5], "same seed and frame, same noise");
	CHECK(a.P != c.P, "another seed, other noise");
	// sigma of thrust noise: 1 % of hover thrust
	double s2 = 0;
	const int N = 4000;
	for (int k = 0; k < N; k++) {
		XpFrame f = xp_measure(m, all(0), 11, static_cast<uint64_t>(k));
		s2 += f.thrust_n[0] * f.thrust_n[0];
	}
	const double sigma = std::sqrt(s2 / N), want = 0.01 * p.mass * p.g / 8;
	CHECK(std::fabs(sigma / want - 1) < 0.05, "thrust sigma %g, want %g", sigma, want);
}

// A clock started at S (--start-time) changes what the plant shows as time, not its
// dynamics: the state after the same frames is the same bit for bit, row 1's mission time
// is the float32 of S + n / rate, and the crash time is on the clock.
TEST(start_time_moves_the_clock_not_the_dynamics)
{
	VehicleParams p; // default noise
	for (double S : {40000.0, 1e6}) {
		Model a(p), b(p);
		b.set_clock_start(S);
		a.command(all(0.7));
		b.command(all(0.7));
		for (int n = 1; n <= 450; n++) {
			a.advance_to(n / 90.0);
			b.advance_to(n / 90.0);
		}
		CHECK(a.state().r == b.state().r && a.state().q.coeffs() == b.state().q.coeffs() &&
			      a.state().w == b.state().w,
		      "S = %g: another state", S);
		CHECK(b.t() == a.t() && b.clock() == S + a.t(), "S = %g: t %.17g clock %.17g", S, b.t(), b.clock());
		XpFrame fa = xp_measure(a, all(0.7), 5, 450), fb = xp_measure(b, all(0.7), 5, 450);
		CHECK(fa.P == fb.P && fa.thrust_n[3] == fb.thrust_n[3], "S = %g: other noise", S);
		xp::DataRow r = xp_row(fb, 1, 12);
		CHECK(r.col[2] == static_cast<float>(S + 5.0), "S = %g: mission time %.9g", S, (double)r.col[2]);
	}
}

// The plant's per-frame form writes every field of the frame it is given: over a frame
// full of another frame's values it gives the very bytes of a fresh one.
TEST(measure_into_a_used_frame_writes_every_field)
{
	VehicleParams p;
	Model m(p);
	m.command(all(0.7));
	m.advance_to(0.5);
	static_assert(std::is_trivially_copyable<XpFrame>::value, "compared as bytes");
	XpFrame used, fresh = xp_measure(m, all(0.7), 3, 45);
	std::memset(static_cast<void *>(&used), 0x5a, sizeof used); // all doubles: no padding
	xp_measure(m, all(0.7), 3, 45, used);
	CHECK(std::memcmp(&used, &fresh, sizeof used) == 0, "a field keeps the value it had");
}

// ------------------------------------------------------------------ byte vectors (layouts in docs/xplane-protocol.md)

TEST(data_out_vector_rows_16_17)
{
	xp::DataRow a{16, {1.5f, -2.25f, 10.0f, xp::kNoData, xp::kNoData, xp::kNoData, xp::kNoData, xp::kNoData}};
	xp::DataRow b{17, {2.0f, -4.5f, 237.75f, 259.25f, xp::kNoData, xp::kNoData, xp::kNoData, xp::kNoData}};
	const std::string want = "444154412a100000000000c03f000010c00000204100c079c400c079c400c079c400c079c400c079c4"
				 "110000000000004000009"
				 "0c000c06d4300a0814300c079c400c079c400c079c400c079c4";
	xp::Bytes d = xp::encode_data({a, b});
	CHECK(d.size() == 77, "size %zu", d.size());
	CHECK(hex(d) == want, "%s", hex(d).c_str());
}

TEST(data_row25_vector_bytes)
{
	xp::DataRow r{25, {0, .125f, .25f, .375f, .5f, .625f, .75f, 1.0f}};
	CHECK(hex(xp::encode_data({r}, 0)) ==
		      "444154410019000000000000000000003e0000803e0000c03e0000003f0000203f0000403f0000803f",
	      "%s", hex(xp::encode_data({r}, 0)).c_str());
}

TEST(rref_reply_vectors)
{
	auto one = xp::encode_rref_replies({{7, 0.25f}});
	CHECK(one.size() == 1 && hex(one[0]) == "525245462c070000000000803e", "%s", hex(one[0]).c_str());
	auto three = xp::encode_rref_replies({{1, 120100.0f}, {7, 0.25f}, {8, -1.5f}});
	CHECK(three.size() == 1 && hex(three[0]) == "525245462c010000000092ea47070000000000803e080000000000c0bf", "%s",
	      hex(three[0]).c_str());
	std::vector<std::pair<int32_t, float>> many;
	for (int i = 0; i < 400; i++)
		many.push_back({i, static_cast<float>(i)});
	auto split = xp::encode_rref_replies(many);
	CHECK(split.size() == 3 && split[0].size() == 5 + 8 * 183 && split[2].size() == 5 + 8 * 34, "split %zu",
	      split.size());
}

TEST(path_fields_and_indices)
{
	uint8_t f[8] = {'a', 'b', 0, ' ', ' ', ' ', ' ', ' '};
	std::string s;
	CHECK(xp::field_path(f, 8, s) && s == "ab", "NUL then spaces");
	uint8_t g[4] = {'a', 'b', 'c', 'd'};
	CHECK(!xp::field_path(g, 4, s), "unterminated");
	std::string base;
	int i;
	CHECK(xp::split_index("x/ENGN_thro_use[7]", base, i) && base == "x/ENGN_thro_use" && i == 7, "index");
	CHECK(!xp::split_index("x[]", base, i) && !xp::split_index("x[a]", base, i) &&
		      !xp::split_index("x[99999]", base, i) && !xp::split_index("x]", base, i),
	      "malformed subscripts");
}

// The definition field_path implements, one byte at a time.
static bool field_path_reference(const uint8_t *f, size_t n, size_t &len)
{
	for (size_t k = 0; k < n; k++) {
		if (f[k] == 0) {
			len = k;
			return k > 0;
		}
		if (f[k] < 0x21 || f[k] > 0x7e)
			return false;
	}
	return false;
}

// Every byte value at every position of paths of 0..24 bytes in fields of 1..40 bytes
// (the eight-byte words and the tail, the NUL anywhere or absent), and random fields,
// against the definition.
TEST(path_field_every_byte_everywhere)
{
	int wrong = 0, cases = 0;
	auto check = [&](const uint8_t *f, size_t n) {
		std::string_view out;
		size_t len = 0;
		const bool want = field_path_reference(f, n, len);
		const bool ok = xp::field_path(f, n, out);
		cases++;
		if (ok != want || (ok && (out.size() != len || out.data() != reinterpret_cast<const char *>(f))))
			wrong++;
	};
	for (size_t n = 1; n <= 40; n++)
		for (size_t nul = 0; nul <= n; nul++) // nul == n: no NUL in the field
			for (size_t at = 0; at < n; at++)
				for (int v = 0; v < 256; v++) {
					uint8_t f[48];
					std::memset(f, 'a', sizeof f);
					for (size_t k = nul + 1; k < n; k++)
						f[k] = static_cast<uint8_t>(0xff - k); // after the NUL: anything
					if (nul < n)
						f[nul] = 0;
					f[at] = static_cast<uint8_t>(v);
					if (at > 0)
						f[at - 1] =
							(v & 1) ? 0x7e : 0x21; // neighbours at both edges of the range
					check(f, n);
				}
	Rng r(5, Stream::Noise, 0);
	for (int i = 0; i < 200000; i++) {
		uint8_t f[48];
		const size_t n = 1 + r.next() % 48;
		for (size_t k = 0; k < n; k++) {
			const uint64_t x = r.next();
			f[k] = static_cast<uint8_t>(x % 16 == 0 ? 0 : x % 16 == 1 ? x >> 8 : 0x21 + (x >> 8) % 0x5e);
		}
		check(f, n);
	}
	CHECK(wrong == 0, "%d of %d fields judged wrongly", wrong, cases);
}

// ------------------------------------------------------------------ JSON and vehicle files

TEST(json_reader)
{
	json::Value v = json::parse(R"({"a": [1, -2.5e1, true, null], "b": {"c": "x\u00e9\n"}})");
	CHECK(v.kind == json::Value::Kind::Object && v.obj.size() == 2, "object");
	CHECK(v.obj[0].second.arr[1].num == -25.0, "number");
	CHECK(v.obj[1].second.obj[0].second.str == "x\xc3\xa9\n", "string escapes");
	CHECK(std::isinf(json::parse("Infinity").num) && std::isnan(json::parse("NaN").num) &&
		      json::parse("-Infinity").num < 0,
	      "non-finite numbers as Python writes them");
	const char *bad[] = {"", "{", "{\"a\":}", "[1,]", "01", "{\"a\":1,\"a\":2}", "\"abc", "nul", "[1] x", "1e999"};
	for (const char *b : bad) {
		bool threw = false;
		try {
			json::parse(b);
		} catch (const json::ParseError &) {
			threw = true;
		}
		CHECK(threw, "'%s' must be rejected", b);
	}
	std::string deep(200, '[');
	bool threw = false;
	try {
		json::parse(deep);
	} catch (const json::ParseError &) {
		threw = true;
	}
	CHECK(threw, "deep nesting rejected");
}

TEST(vehicle_keys)
{
	VehicleParams p;
	vehicle_from_json(R"({"mass": 3, "inertia": [0.1, 0.2, 0.3], "noise": {"gyro": 0.01},
	                      "rotor_scale": [1,1,1,1,1,1,1,0], "origin": [10, 20, 30]})",
			  p);
	CHECK(p.mass == 3 && p.inertia[2] == 0.3 && p.noise.gyro == 0.01 && p.rotor_scale[7] == 0, "applied");
	CHECK(p.kf == 28.0269, "absent keys keep defaults");
	struct {
		const char *text, *key;
	} bad[] = {
		{R"({"mass": 0})", "mass"},
		{R"({"mass": -2})", "mass"},
		{R"({"inertia": [1, 0, 1]})", "inertia"},
		{R"({"inertia": [1, 1]})", "inertia"},
		{R"({"bogus": 1})", "bogus"},
		{R"({"noise": {"gyr": 1}})", "noise.gyr"},
		{R"({"kf": "x"})", "kf"},
		{R"({"thrust_curve": 2})", "thrust_curve"},
		{R"({"rotor_scale": [1]})", "rotor_scale"},
		{R"({"motor_tau": -1})", "motor_tau"},
		{R"({"g": NaN})", "g"},
		{R"({"inertia": [1, Infinity, 1]})", "inertia"},
		{R"({"noise": {"gyro": -Infinity}})", "noise.gyro"},
	};
	for (const auto &b : bad) {
		std::string key = "?";
		try {
			VehicleParams q;
			vehicle_from_json(b.text, q);
		} catch (const VehicleError &e) {
			key = e.key;
		}
		CHECK(key == b.key, "%s: key '%s'", b.text, key.c_str());
	}
}

// ------------------------------------------------------------------ fuzz (most useful under make sim-asan)

TEST(fuzz_json_and_vehicle_never_crash)
{
	Rng r(1, Stream::Noise, 0);
	const std::string alphabet = "{}[]\",:.-+eE0123456789 \n\\truefalsnNaIinfy\"massgkfinertia";
	const std::string seed = R"({"mass": 2, "inertia": [0.1, 0.2, 0.3], "noise": {"gyro": 0.01}})";
	int parsed = 0;
	for (int k = 0; k < 20000; k++) {
		std::string t = seed;
		const int edits = 1 + static_cast<int>(r.next() % 6);
		for (int e = 0; e < edits; e++) {
			const size_t pos = r.next() % (t.size() + 1);
			const char c = alphabet[r.next() % alphabet.size()];
			switch (r.next() % 3) {
			case 0: t.insert(pos, 1, c); break;
			case 1:
				if (pos < t.size())
					t.erase(pos, 1);
				break;
			default:
				if (pos < t.size())
					t[pos] = c;
				break;
			}
		}
		try {
			VehicleParams p;
			vehicle_from_json(t, p);
			parsed++;
			if (!(p.mass > 0 && p.inertia[0] > 0 && p.inertia[1] > 0 && p.inertia[2] > 0 &&
			      std::isfinite(p.g)))
				CHECK(false, "accepted an impossible vehicle: %s", t.c_str());
		} catch (const VehicleError &) {
		}
	}
	CHECK(parsed > 0, "some mutations stay valid");
}

static std::vector<uint8_t> dref_bytes(float v, const char *path, size_t path_len)
{
	std::vector<uint8_t> b(xp::kDrefSize, 0);
	std::memcpy(b.data(), "DREF", 4);
	std::memcpy(b.data() + 5, &v, 4);
	std::memcpy(b.data() + 9, path, path_len);
	return b;
}

// The throttle DREFs taken by their bytes give what the full decoding gives: the same
// throttle written by "[d]" and by "[0d]" (decoded in full), and the counters of the
// full decoding for fields that only look like them.
TEST(dref_throttle_by_bytes_as_in_full)
{
	const float values[] = {0.0f, 0.37f, 1.0f, 1.5f, -0.2f, NAN, INFINITY};
	int differ = 0;
	for (int d = 0; d < 10; d++)
		for (float v : values) {
			Counters ca, cb;
			XpInput a(ca), b(cb);
			sockaddr_in from{};
			char p1[64], p2[64];
			std::snprintf(p1, sizeof p1, "sim/flightmodel/engine/ENGN_thro_use[%d]", d);
			std::snprintf(p2, sizeof p2, "sim/flightmodel/engine/ENGN_thro_use[0%d]", d);
			auto x = dref_bytes(v, p1, std::strlen(p1)), y = dref_bytes(v, p2, std::strlen(p2));
			x[9 + std::strlen(p1) + 1] = 'z'; // after the NUL: not part of the path
			a.handle(x.data(), x.size(), from);
			b.handle(y.data(), y.size(), from);
			if (a.thro_use != b.thro_use || a.cmd_mask != b.cmd_mask ||
			    std::memcmp(ca.v, cb.v, sizeof ca.v))
				differ++;
		}
	CHECK(differ == 0, "%d of 70 throttle DREFs decoded otherwise", differ);
	struct {
		const char *path;
		size_t len;
		Counters::Id counter; // Count: a throttle written
	} near[] = {
		{"sim/flightmodel/engine/ENGN_thro_use[7]x", 40, Counters::RxIgnoredDref},
		{"sim/flightmodel/engine/ENGN_thro_use[7] ", 40, Counters::RxUnterminated},
		{"sim/flightmodel/engine/ENGN_thro_use[a]", 39, Counters::RxIgnoredDref},
		{"sim/flightmodel/engine/ENGN_thro_use[7", 38, Counters::RxIgnoredDref},
		{"sim/flightmodel/engine/ENGN_thro_use[]", 38, Counters::RxIgnoredDref},
		{"sim/flightmodel/engine/ENGN_thro_use[15]", 40, Counters::Count},
		{"sim/flightmodel/engine/ENGN_thro_use[16]", 40, Counters::RxIgnoredDref},
		{"sim/flightmodel/engine/ENGN_thro[7]", 35, Counters::Count},
	};
	for (const auto &n : near) {
		Counters c;
		XpInput in(c);
		sockaddr_in from{};
		auto x = dref_bytes(0.25f, n.path, n.len);
		in.handle(x.data(), x.size(), from);
		const bool wrote = in.thro_use[7] == 0.25f || in.thro_use[15] == 0.25f || in.thro[7] == 0.25f;
		const bool ok = n.counter == Counters::Count ? wrote && c[Counters::RxIgnoredDref] == 0
							     : !wrote && c[n.counter] == 1;
		CHECK(ok, "%s", n.path);
	}
}

TEST(fuzz_xplane_input_never_crashes)
{
	Counters c;
	XpInput in(c);
	Rng r(2, Stream::Noise, 0);
	sockaddr_in from{};
	std::vector<uint8_t> b;
	bool in_range = true;
	const char *tags[] = {"DATA", "DREF", "RREF", "DSEL", "USEL", "CMND", "ISE4", "XXXX"};
	for (int k = 0; k < 50000; k++) {
		const size_t sizes[] = {0, 3, 5, 9, 13, 37, 41, 77, 412, 413, 414, 508, 509, 510, 1500};
		size_t n = sizes[r.next() % 15];
		b.resize(n);
		for (auto &x : b)
			x = static_cast<uint8_t>(r.next() % 4 ? r.next() : 0);
		if (n >= 4)
			std::memcpy(b.data(), tags[r.next() % 8], 4);
		in.handle(b.data(), b.size(), from);
		for (size_t j = 0; j < 16; j++)
			in_range = in_range && in.thro[j] >= 0 && in.thro[j] <= 1 && in.thro_use[j] >= 0 &&
				   in.thro_use[j] <= 1;
	}
	CHECK(in_range, "throttles stay in [0, 1]");
	CHECK(c[Counters::RxDatagrams] == 50000, "all counted");
	CHECK(in.subs.size() <= XpInput::kMaxSubs, "subscriptions bounded");
}

// ------------------------------------------------------------------ sensors (docs/sensors.md)

// A vehicle with no noise, lag or delay, and one sensor term switched on by the test.
static VehicleParams quiet()
{
	VehicleParams p = ideal();
	p.vibration.sample_hz = 1800.0; // a multiple of 90 Hz: the read falls on a sample
	return p;
}

// Specific force over g in the body, from the three load factors (FLU).
static Eigen::Vector3d sf_g(const XpFrame &f) { return Eigen::Vector3d(f.g_axil, -f.g_side, f.g_nrml); }

TEST(imu_static_reads_plus_one_g_up)
{
	VehicleParams p = quiet();
	Model m(p);
	XpFrame f = xp_measure(m, all(0), 1, 0);
	CHECK(f.g_nrml == 1.0 && f.g_axil == 0.0 && f.g_side == 0.0, "at rest: %g %g %g", f.g_nrml, f.g_axil, f.g_side);
	xp::DataRow r4 = xp_row(f, 4, 12);
	CHECK(r4.col[4] == 1.0f && r4.col[5] == 0.0f && r4.col[6] == 0.0f, "row 4 c5..c7");
	// steady hover in the air: the thrust holds the weight, +1 g along the body's up
	BodyState x;
	x.r = Eigen::Vector3d(0, 0, 10);
	x.s = all(p.hover_throttle());
	m.set_state(x, 0.0);
	f = xp_measure(m, all(p.hover_throttle()), 1, 0);
	CHECK(std::fabs(f.g_nrml - 1.0) < 1e-12 && std::fabs(f.g_axil) < 1e-12, "hover %g", f.g_nrml);
	// twice the hover thrust: 2 g; rotors off in the air (free fall): 0 g
	x.s = all(2 * p.hover_throttle());
	m.set_state(x, 0.0);
	f = xp_measure(m, all(0), 1, 0);
	CHECK(std::fabs(f.g_nrml - 2.0) < 1e-12, "2 x hover thrust %g", f.g_nrml);
	x.s = all(0);
	x.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
	m.set_state(x, 0.0);
	f = xp_measure(m, all(0), 1, 0);
	CHECK(sf_g(f).norm() < 1e-12, "free fall reads 0 g: %g", sf_g(f).norm());
	// the model's only force is the thrust along +Z_B: a forward or sideways specific force
	// (here a bias) maps to g axial forward-positive and g side right-positive
	Sensors sn(p, 1, 90.0);
	sn.bias_a = Eigen::Vector3d(0.1 * p.g, 0.2 * p.g, 0); // forward, left (FLU)
	xp_measure(m, all(0), 1, 0, sn, f);
	CHECK(std::fabs(f.g_axil - 0.1) < 1e-12 && std::fabs(f.g_side + 0.2) < 1e-12, "axial %g side %g", f.g_axil,
	      f.g_side);
}

TEST(imu_white_noise_levels)
{
	VehicleParams p = quiet();
	p.noise.accel = 0.05;
	p.noise.gyro = 0.01;
	Model m(p);
	const int N = 4000;
	double sa = 0, sg = 0, ma = 0;
	for (int k = 0; k < N; k++) {
		XpFrame f = xp_measure(m, all(0), 5, static_cast<uint64_t>(k));
		const double e = (f.g_nrml - 1.0) * p.g;
		ma += e;
		sa += e * e;
		sg += f.P * f.P;
	}
	// the sample sd's relative sd is 1/sqrt(2N) = 1.1 %: 5 % is beyond 4 sd
	CHECK(std::fabs(std::sqrt(sa / N) / 0.05 - 1) < 0.05, "accel sd %g", std::sqrt(sa / N));
	CHECK(std::fabs(ma / N) < 4 * 0.05 / std::sqrt(N), "accel mean %g", ma / N);
	CHECK(std::fabs(std::sqrt(sg / N) / 0.01 - 1) < 0.05, "gyro sd %g", std::sqrt(sg / N));
}

// The IMU's draws come from streams of their own: the rows' white noise is drawn as before.
TEST(imu_keeps_the_noise_stream)
{
	VehicleParams p; // every default on
	Model m(p);
	Sensors s(p, 9, 90.0);
	m.command(all(0.3));
	for (uint64_t n = 1; n <= 30; n++) {
		m.advance_to(static_cast<double>(n) / 90.0);
		s.advance(m, n);
	}
	XpFrame f;
	xp_measure(m, all(0.3), 9, 30, s, f);
	Rng r(9, Stream::Noise, 30);
	const double want_p = s.gyro(m.state().w).x() + p.noise.gyro * r.gauss();
	CHECK(f.P == want_p, "P %.17g, want %.17g", f.P, want_p);
	for (int i = 0; i < 8; i++)
		r.gauss(); // Q, R, attitude, position
	const RotorOutputs o = m.rotor_outputs(m.state(), m.t());
	CHECK(f.thrust_n[0] == o.thrust[0] + p.sigma_thrust() * r.gauss(), "thrust noise is the same draw");
	// deterministic from the seed
	Sensors s2(p, 9, 90.0), s3(p, 10, 90.0);
	CHECK(s2.bias_a == s.bias_a && s2.scale_g == s.scale_g && s3.bias_a != s.bias_a, "per-run draws from the seed");
}

TEST(imu_bias_scale_and_walk)
{
	VehicleParams p = quiet();
	p.imu_bias = ImuBiasParams{0.05, 0.002, 0.01, 0.001};
	p.imu_scale = 0.01;
	const int M = 1000;
	double b2 = 0, s2 = 0, w90 = 0, w360 = 0, g360 = 0;
	Model m(p); // at rest: the walk does not depend on the motion
	for (int seed = 1; seed <= M; seed++) {
		Sensors s(p, static_cast<uint64_t>(seed), 90.0);
		b2 += s.bias_a.squaredNorm() / 3;
		s2 += s.scale_g.squaredNorm() / 3;
		for (uint64_t n = 1; n <= 360; n++) {
			s.advance(m, n);
			if (n == 90)
				w90 += s.walk_a.squaredNorm() / 3;
		}
		w360 += s.walk_a.squaredNorm() / 3;
		g360 += s.walk_g.squaredNorm() / 3;
	}
	// variances over 3000 draws: relative sd sqrt(2/3000) = 2.6 %; 12 % is beyond 4 sd
	CHECK(std::fabs(std::sqrt(b2 / M) / 0.05 - 1) < 0.06, "constant bias sd %g", std::sqrt(b2 / M));
	CHECK(std::fabs(std::sqrt(s2 / M) / 0.01 - 1) < 0.06, "scale sd %g", std::sqrt(s2 / M));
	// the walk's variance grows linearly with time: sd^2 t at 1 s and at 4 s
	CHECK(std::fabs(w90 / M / (0.01 * 0.01 * 1.0) - 1) < 0.12, "walk var at 1 s %g", w90 / M);
	CHECK(std::fabs(w360 / M / (0.01 * 0.01 * 4.0) - 1) < 0.12, "walk var at 4 s %g", w360 / M);
	CHECK(std::fabs(g360 / M / (0.001 * 0.001 * 4.0) - 1) < 0.12, "gyro walk var at 4 s %g", g360 / M);
	// the reading: (1 + scale) x + bias + walk
	Sensors s(p, 3, 90.0);
	const Eigen::Vector3d w(0.5, -1, 2);
	const Eigen::Vector3d want = w + s.scale_g.cwiseProduct(w) + s.bias_g + s.walk_g + s.vib_g;
	CHECK((s.gyro(w) - want).norm() < 1e-15, "gyro reading");
}

// Amplitude of x at frequency f (Hz) from samples at rate fs (a single DFT bin).
static double amplitude(const std::vector<double> &x, double f, double fs)
{
	double re = 0, im = 0;
	for (size_t k = 0; k < x.size(); k++) {
		const double a = 2 * M_PI * f * static_cast<double>(k) / fs;
		re += x[k] * std::cos(a);
		im -= x[k] * std::sin(a);
	}
	return 2 * std::hypot(re, im) / static_cast<double>(x.size());
}

// One rotor spinning at rotor_hz; the x vibration of the accelerometer read at 90 Hz.
static std::vector<double> vibration_read(VehicleParams p, double rotor_hz, size_t frames)
{
	Model m(p); // the body's motion plays no part: only the rotor speed does
	Sensors s(p, 4, 90.0);
	const double rev_per_s = p.rpm_max / 60.0;
	RotorArray u = all(0);
	u[0] = (rotor_hz / rev_per_s) * (rotor_hz / rev_per_s); // g(s) = s: speed ~ sqrt(s)
	m.command(u);
	std::vector<double> x;
	for (uint64_t n = 1; n <= frames + 90; n++) {
		m.advance_to(static_cast<double>(n) / 90.0);
		s.advance(m, n);
		if (n > 90) // after the filter's start
			x.push_back(s.vib_a.x());
	}
	return x;
}

TEST(vibration_aliases_at_the_frame_rate_through_the_filter)
{
	VehicleParams p = quiet();
	p.vibration.accel = 1.0;
	p.vibration.harmonics = {{1.0, 0.0, 0.0, 0.0}};
	const double f_rot = 70.0, fs = p.vibration.sample_hz;
	const double hover_hz = hover_rotor_speed(p) / (2 * M_PI);
	const double a_rot = 1.0 * (f_rot / hover_hz) * (f_rot / hover_hz); // ~ speed^2
	Biquad lp;
	lp.design(p.vibration.cutoff_hz, fs);
	const std::vector<double> x = vibration_read(p, f_rot, 900);
	// 70 Hz read at 90 Hz appears at 20 Hz, attenuated by the filter's gain at 70 Hz
	const double peak = amplitude(x, 20.0, 90.0), want = a_rot * lp.gain(f_rot, fs);
	CHECK(std::fabs(peak / want - 1) < 0.03, "alias peak %g, want %g", peak, want);
	double other = 0;
	for (int b = 1; b < 450; b++)
		if (b != 200)
			other = std::max(other, amplitude(x, b * 0.1, 90.0));
	CHECK(other < 0.05 * peak, "one peak: largest other bin %g of %g", other, peak);
	// the filter is a 2nd-order Butterworth: |H| = 1 / sqrt(1 + (f/fc)^4) (bilinear: close)
	const double analog = 1 / std::sqrt(1 + std::pow(f_rot / p.vibration.cutoff_hz, 4));
	CHECK(std::fabs(lp.gain(f_rot, fs) / analog - 1) < 0.1, "gain %g, analog %g", lp.gain(f_rot, fs), analog);
	CHECK(std::fabs(lp.gain(0.0, fs) - 1) < 1e-12, "unit DC gain");
	// a higher cutoff lets more through, by the ratio of the gains
	VehicleParams q = p;
	q.vibration.cutoff_hz = 300.0;
	Biquad hp;
	hp.design(300.0, fs);
	const double peak_q = amplitude(vibration_read(q, f_rot, 900), 20.0, 90.0);
	CHECK(std::fabs(peak_q / peak / (hp.gain(f_rot, fs) / lp.gain(f_rot, fs)) - 1) < 0.03, "cutoff ratio %g",
	      peak_q / peak);
	// the second harmonic (140 Hz) folds to 40 Hz
	q = p;
	q.vibration.harmonics = {{0.0, 1.0, 0.0, 0.0}};
	const std::vector<double> x2 = vibration_read(q, f_rot, 900);
	const double p40 = amplitude(x2, 40.0, 90.0);
	CHECK(std::fabs(p40 / (a_rot * lp.gain(2 * f_rot, fs)) - 1) < 0.03, "2x at 40 Hz %g", p40);
	// none when the vibration is off
	q.vibration.accel = 0;
	const std::vector<double> x0 = vibration_read(q, f_rot, 90);
	CHECK(amplitude(x0, 40.0, 90.0) == 0.0, "off");
}

TEST(rpm_follows_the_lagged_throttle_and_dshot_quantises)
{
	VehicleParams p = quiet();
	p.motor_tau = 0.05;
	p.thrust_curve = 0.4;
	Model m(p);
	m.set_ground(false);
	m.command(all(0.6));
	m.advance_to(0.05);
	XpFrame f = xp_measure(m, all(0.6), 1, 5);
	const RotorOutputs o = m.rotor_outputs(m.state(), m.t());
	// speed^2 is proportional to thrust (one constant), at the lagged output s
	const double c = f.rpm_true[0] * f.rpm_true[0] / o.thrust[0];
	CHECK(std::fabs(c * p.kf / (p.rpm_max * p.rpm_max) - 1) < 1e-12, "rpm^2 / thrust");
	CHECK(f.rpm_true[0] < 0.99 * p.rpm_max * std::sqrt(thrust_curve(0.4, 0.6)), "lagged");
	// DShot: the period in us, a 9-bit mantissa shifted by the exponent
	const double pp = 7;
	CHECK(dshot_rpm(0, pp) == 0 && dshot_rpm(10, pp) == 0, "stopped reads 0");
	CHECK(std::fabs(dshot_rpm(9000, pp) - 60e6 / (952 * pp)) < 1e-9, "9000 rpm: period 952 us");
	double last = -1;
	int steps = 0;
	for (double r = 500; r < 12000; r += 0.25) {
		const double q = dshot_rpm(r, pp);
		const double period = 60e6 / (q * pp);
		const double true_period = 60e6 / (r * pp);
		int e = 0;
		while ((std::lround(true_period) >> e) > 511)
			e++;
		const double step = static_cast<double>(1 << e);
		// the reported period is a whole multiple of the step, within half a step (+ rounding to us)
		const double mult = period / step;
		CHECK(std::fabs(mult - std::round(mult)) < 1e-6 &&
			      std::fabs(period - true_period) <= step / 2 + 0.5 + 1e-9,
		      "rpm %g: period %g, true %g, step %g", r, period, true_period, step);
		if (q != last)
			steps++;
		last = q;
	}
	CHECK(steps > 100, "quantised into %d values", steps);
	// report noise: sd near noise.rpm (quantisation adds step^2 / 12)
	p.noise.rpm = 50;
	Model h(p);
	h.set_ground(false);
	h.command(all(0.3));
	h.advance_to(1.0);
	double s1 = 0, s2 = 0;
	const int N = 4000;
	for (int k = 0; k < N; k++) {
		XpFrame g = xp_measure(h, all(0.3), 2, static_cast<uint64_t>(k));
		const double e = g.rpm[3] - g.rpm_true[3];
		s1 += e;
		s2 += e * e;
	}
	const double sd = std::sqrt(s2 / N - (s1 / N) * (s1 / N));
	CHECK(std::fabs(sd / 50 - 1) < 0.06, "rpm noise sd %g", sd);
	xp::DataRow r37 = xp_row(f, 37, 12), r38 = xp_row(f, 38, 12);
	CHECK(r37.col[2] == static_cast<float>(f.rpm[2]) && r38.col[2] == r37.col[2], "rows 37/38 report the ESC rpm");
}

TEST(torque_from_esc_current_offset_and_noise)
{
	VehicleParams p = quiet();
	p.esc_kt = 0.02;
	p.esc_current_offset = 0.5;
	p.noise.current = 0.1;
	Model m(p);
	m.command(all(0.3));
	m.advance_to(0.5);
	double s1 = 0, s2 = 0;
	const int N = 4000;
	for (int k = 0; k < N; k++) {
		XpFrame f = xp_measure(m, all(0.3), 6, static_cast<uint64_t>(k));
		const double e = f.torque_nm[1] - f.torque_abs_nm[1];
		s1 += e;
		s2 += e * e;
	}
	const double mean = s1 / N, sd = std::sqrt(s2 / N - mean * mean);
	CHECK(std::fabs(mean - 0.02 * 0.5) < 4 * 0.002 / std::sqrt(N), "offset Kt * I0: %g", mean);
	CHECK(std::fabs(sd / 0.002 - 1) < 0.05, "current noise Kt * sd: %g", sd);
}

TEST(sensors_served_and_ideal)
{
	unsigned b = 0;
	std::string bad;
	CHECK(sensors_parse("imu", b, bad) && b == kSensorImu, "imu");
	CHECK(sensors_parse("thrust,rpm", b, bad) && b == (kSensorThrust | kSensorRpm), "two");
	CHECK(!sensors_parse("imu,gps", b, bad) && bad == "gps", "unknown");
	CHECK(!sensors_parse("", b, bad), "empty");
	CHECK(xp_row_served(4, kSensorImu) && xp_row_served(16, kSensorImu) && !xp_row_served(35, kSensorImu) &&
		      !xp_row_served(36, kSensorImu) && !xp_row_served(37, kSensorImu) &&
		      !xp_row_served(38, kSensorImu) && xp_row_served(17, kSensorImu),
	      "imu rows");
	CHECK(!xp_row_served(16, kSensorThrust) && xp_row_served(35, kSensorThrust), "thrust rows");
	CHECK(!xp_dataref_served("sim/flightmodel/position/Prad", kSensorRpm) &&
		      xp_dataref_served("sim/flightmodel/engine/POINT_tacrad[3]", kSensorRpm) &&
		      !xp_dataref_served("sim/flightmodel/engine/ENGN_TRQ[0]", kSensorRpm) &&
		      xp_dataref_served("sim/flightmodel/position/theta", 0),
	      "datarefs");
	VehicleParams p;
	vehicle_from_json(R"({"sensors": ["imu", "rpm"], "noise": {"accel": 0.1, "rpm": 3, "current": 0.2},
	                      "imu_bias": {"gyro_walk": 0.01}, "imu_scale": 0.02, "esc_current_offset": -0.1,
	                      "vibration": {"accel": 2, "harmonics": [1, 0.5], "cutoff_hz": 40, "sample_hz": 8000}})",
			  p);
	CHECK(p.sensors == (kSensorImu | kSensorRpm) && p.noise.accel == 0.1 && p.noise.rpm == 3 &&
		      p.imu_bias.gyro_walk == 0.01 && p.imu_bias.accel == 0.05 && p.vibration.harmonics[1] == 0.5 &&
		      p.vibration.harmonics[2] == 0 && p.vibration.sample_hz == 8000 && p.esc_current_offset == -0.1,
	      "sensor keys applied");
	const char *badkeys[][2] = {
		{R"({"sensors": ["imu", "sonar"]})", "sensors"},
		{R"({"sensors": []})", "sensors"},
		{R"({"imu_bias": {"accel": -1}})", "imu_bias.accel"},
		{R"({"imu_bias": {"x": 1}})", "imu_bias.x"},
		{R"({"vibration": {"cutoff_hz": 600}})", "vibration.cutoff_hz"},
		{R"({"vibration": {"harmonics": [1, 1, 1, 1, 1]}})", "vibration.harmonics"},
		{R"({"noise": {"rpm": -1}})", "noise.rpm"},
		{R"({"esc_pole_pairs": 6.5})", "esc_pole_pairs"},
		{R"({"imu_scale": 1})", "imu_scale"},
	};
	for (const auto &k : badkeys) {
		std::string key = "?";
		try {
			VehicleParams q;
			vehicle_from_json(k[0], q);
		} catch (const VehicleError &e) {
			key = e.key;
		}
		CHECK(key == k[1], "%s: key '%s'", k[0], key.c_str());
	}
	// --ideal: every sensor term zero (the rpm keeps DShot's resolution)
	VehicleParams q;
	q.make_ideal();
	Model m(q); // lifts off: the thrust exceeds the weight
	m.command(all(0.5));
	Sensors s(q, 3, 90.0);
	for (uint64_t n = 1; n <= 45; n++) {
		m.advance_to(static_cast<double>(n) / 90.0);
		s.advance(m, n);
	}
	XpFrame f;
	xp_measure(m, all(0.5), 3, 45, s, f);
	const RotorOutputs o = m.rotor_outputs(m.state(), m.t());
	CHECK(std::fabs(f.g_nrml - o.force / q.mass / q.g) < 1e-12 && std::fabs(f.g_axil) < 1e-12 &&
		      std::fabs(f.g_side) < 1e-12,
	      "ideal accel %.17g %.17g %g %g", f.g_nrml, o.force / q.mass / q.g, f.g_axil, f.g_side);
	CHECK(f.P == m.state().w.x() && f.torque_nm[2] == f.torque_abs_nm[2] && f.thrust_n[2] == o.thrust[2],
	      "ideal gyro, torque, thrust");
	CHECK(f.rpm[2] == dshot_rpm(f.rpm_true[2], q.esc_pole_pairs), "ideal rpm: DShot's resolution only");
}

// --imu-spike P: about P of the frames carry one outlier, on each of the six IMU axes and with
// both signs, of exactly the configured size; the other frames read as without spikes.
TEST(imu_spike_replaces_one_axis)
{
	VehicleParams p = quiet();
	p.noise.gyro = 0.01;
	p.noise.accel = 0.05;
	VehicleParams q = p;
	q.imu_spike = ImuSpikeParams{0.1, 3.0, 40.0};
	Model mp(p), mq(q);
	const int N = 9000;
	int spikes = 0, pos = 0, axis_hits[6] = {0, 0, 0, 0, 0, 0};
	bool others_same = true, exact = true;
	for (int k = 0; k < N; k++) {
		const XpFrame a = xp_measure(mp, all(0), 7, static_cast<uint64_t>(k));
		const XpFrame b = xp_measure(mq, all(0), 7, static_cast<uint64_t>(k));
		const double va[6] = {a.P, a.Q, a.R, a.g_axil, a.g_side, a.g_nrml};
		const double vb[6] = {b.P, b.Q, b.R, b.g_axil, b.g_side, b.g_nrml};
		int changed = 0;
		for (int i = 0; i < 6; i++) {
			if (va[i] == vb[i])
				continue;
			changed++;
			axis_hits[i]++;
			const double size = i < 3 ? 3.0 : 40.0 / q.g;
			exact = exact && std::fabs(vb[i]) == size;
			pos += vb[i] > 0;
		}
		others_same = others_same && changed <= 1 && a.roll == b.roll && a.rpm[0] == b.rpm[0];
		spikes += changed;
	}
	// binomial sd sqrt(0.1 0.9 / 9000) = 0.0032: 0.013 is 4 sd
	CHECK(std::fabs(spikes / double(N) - 0.1) < 0.013, "spike rate %g", spikes / double(N));
	for (int i = 0; i < 6; i++)
		CHECK(axis_hits[i] > 90, "axis %d hit %d times", i, axis_hits[i]);
	CHECK(pos > spikes / 3 && pos < 2 * spikes / 3, "signs %d of %d positive", pos, spikes);
	CHECK(exact, "outliers of the configured size");
	CHECK(others_same, "one axis per spike, the other rows unchanged");
}

// --stuck-rpm J@T: rotor J's report keeps its value from the first frame at or after T while
// its speed changes; the other rotors' reports follow their speeds.
TEST(stuck_rpm_freezes_one_report)
{
	VehicleParams p = quiet();
	p.stuck_rpm.push_back(StuckRpm{2, 0.5});
	Model m(p);
	Sensors s(p, 3, 90.0);
	XpFrame f;
	double frozen = -1, first_rpm0 = -1;
	bool held = true, before_free = true;
	for (uint64_t n = 1; n <= 180; n++) {
		const double u = 0.2 + 0.5 * static_cast<double>(n) / 180.0; // a throttle ramp
		m.command(all(u));
		m.advance_to(static_cast<double>(n) / 90.0);
		s.advance(m, n);
		xp_measure(m, all(u), 3, n, s, f);
		const double live = f.rpm[2];
		s.hold_stuck_rpm(m.clock(), f.rpm);
		if (m.clock() < 0.5) {
			before_free = before_free && f.rpm[2] == live;
		} else {
			if (frozen < 0) {
				frozen = live;
				first_rpm0 = f.rpm[0];
			}
			held = held && f.rpm[2] == frozen;
		}
	}
	CHECK(before_free, "the report is live before T");
	CHECK(frozen > 0 && held, "frozen at %g", frozen);
	CHECK(f.rpm_true[2] > 1.2 * frozen, "the rotor sped up (%g rpm) under its frozen report", f.rpm_true[2]);
	CHECK(f.rpm[0] > 1.2 * first_rpm0, "rotor 1's report follows its speed: %g from %g", f.rpm[0], first_rpm0);
}

// The flags and keys of the IMU spikes and the stuck report; bad values refused, naming the key.
TEST(imu_spike_and_stuck_rpm_flags_and_keys)
{
	auto parse = [](std::vector<std::string> args, Options &o) {
		std::vector<char *> argv;
		static char prog[] = "octo-sim";
		argv.push_back(prog);
		for (auto &a : args)
			argv.push_back(&a[0]);
		return parse_options(static_cast<int>(argv.size()), argv.data(), o);
	};
	Options o;
	CHECK(parse({"--imu-spike", "0.02", "--imu-spike-gyro", "3", "--imu-spike-accel", "20", "--stuck-rpm", "2@4.5",
		     "--stuck-rpm", "8@0"},
		    o) == -1,
	      "parsed");
	const auto &v = o.vehicle;
	CHECK(v.imu_spike.prob == 0.02 && v.imu_spike.gyro == 3 && v.imu_spike.accel == 20, "spike values");
	CHECK(v.stuck_rpm.size() == 2 && v.stuck_rpm[0].rotor == 1 && v.stuck_rpm[0].at_s == 4.5 &&
		      v.stuck_rpm[1].rotor == 7 && v.stuck_rpm[1].at_s == 0,
	      "stuck values");
	Options d;
	CHECK(parse({}, d) == -1 && d.vehicle.imu_spike.prob == 0 && d.vehicle.stuck_rpm.empty(), "off by default");
	for (auto bad : std::vector<std::vector<std::string>>{{"--imu-spike", "1.5"},
							      {"--imu-spike", "-0.1"},
							      {"--imu-spike", "x"},
							      {"--imu-spike-gyro", "0"},
							      {"--imu-spike-accel", "-3"},
							      {"--stuck-rpm", "0@1"},
							      {"--stuck-rpm", "9@1"},
							      {"--stuck-rpm", "3"},
							      {"--stuck-rpm", "3@-1"},
							      {"--stuck-rpm", "3@nan"},
							      {"--stuck-rpm", "3@1:0.5"}}) {
		Options q;
		std::fprintf(stderr, "  (expected) ");
		CHECK(parse(bad, q) == 2, "%s %s accepted", bad[0].c_str(), bad[1].c_str());
	}
	VehicleParams p;
	vehicle_from_json(R"({"imu_spike": {"prob": 0.01, "gyro": 2}, "stuck_rpm": {"rotor": 5, "at_s": 7}})", p);
	CHECK(p.imu_spike.prob == 0.01 && p.imu_spike.gyro == 2 && p.imu_spike.accel == 50, "spike key");
	CHECK(p.stuck_rpm.size() == 1 && p.stuck_rpm[0].rotor == 4 && p.stuck_rpm[0].at_s == 7, "stuck key");
	vehicle_from_json(R"({"stuck_rpm": [{"rotor": 1, "at_s": 3}, {"rotor": 2, "at_s": 4}]})", p);
	CHECK(p.stuck_rpm.size() == 2 && p.stuck_rpm[1].rotor == 1, "stuck list");
	const char *bad_keys[][2] = {{R"({"imu_spike": {"prob": 2}})", "imu_spike.prob"},
				     {R"({"imu_spike": {"gyro": 0}})", "imu_spike.gyro"},
				     {R"({"imu_spike": {"size": 1}})", "imu_spike.size"},
				     {R"({"imu_spike": 0.1})", "imu_spike"},
				     {R"({"stuck_rpm": {"rotor": 9, "at_s": 1}})", "stuck_rpm.rotor"},
				     {R"({"stuck_rpm": {"rotor": 1}})", "stuck_rpm"},
				     {R"({"stuck_rpm": {"rotor": 1, "at_s": -1}})", "stuck_rpm.at_s"},
				     {R"({"stuck_rpm": {"rotor": 1, "at_s": 1, "scale": 0}})", "stuck_rpm.scale"}};
	for (const auto &k : bad_keys) {
		std::string key;
		try {
			VehicleParams q;
			vehicle_from_json(k[0], q);
		} catch (const VehicleError &e) {
			key = e.key;
		}
		CHECK(key == k[1], "%s: key '%s'", k[0], key.c_str());
	}
}

int main()
{
	for (const auto &t : registry()) {
		g_test = t.name;
		int before = g_failed;
		t.fn();
		std::printf("%s %s\n", g_failed == before ? "ok  " : "FAIL", t.name);
	}
	std::printf("%zu tests, %d checks, %d failed\n", registry().size(), g_checks, g_failed);
	return g_failed ? 1 : 0;
}
