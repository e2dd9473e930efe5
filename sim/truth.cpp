// truth: octo.truth_t filled from the model and written to LCM.
#include "truth.hpp"

#include <lcm/eventlog.h>
#include <lcm/lcm-cpp.hpp>
#include <octo/truth_t.hpp>

#include <cmath>
#include <vector>

namespace sim
{

static const char kChannel[] = "OCTO_TRUTH";

struct TruthPublisher::Impl {
	std::unique_ptr<lcm::LCM> lcm;
	lcm_eventlog_t *log = nullptr;
	int64_t eventnum = 0;
	unsigned every = 1;
	std::vector<uint8_t> buf;
	~Impl()
	{
		if (log)
			lcm_eventlog_destroy(log);
	}
};

TruthPublisher::TruthPublisher() : d_(new Impl) {}
TruthPublisher::~TruthPublisher() = default;

bool TruthPublisher::active() const { return d_->lcm || d_->log; }

bool TruthPublisher::open(const std::string &url, std::string &err)
{
	const std::string file = "file://";
	if (url.compare(0, file.size(), file) == 0) {
		std::string path = url.substr(file.size());
		std::string mode = "w";
		size_t qm = path.find('?');
		if (qm != std::string::npos) {
			std::string opts = path.substr(qm + 1);
			path = path.substr(0, qm);
			if (opts.find("mode=a") != std::string::npos)
				mode = "a";
			else if (opts.find("mode=r") != std::string::npos) {
				err = "a read-mode log cannot take the truth";
				return false;
			}
		}
		d_->log = lcm_eventlog_create(path.c_str(), mode.c_str());
		if (!d_->log) {
			err = "cannot open LCM log '" + path + "'";
			return false;
		}
		return true;
	}
	d_->lcm.reset(new lcm::LCM(url));
	if (!d_->lcm->good()) {
		d_->lcm.reset();
		err = "cannot open LCM URL '" + url + "'";
		return false;
	}
	return true;
}

void TruthPublisher::set_every(unsigned every) { d_->every = every ? every : 1; }

void TruthPublisher::publish(const Model &m, uint64_t frame)
{
	if (!active() || frame % d_->every != 0)
		return;
	const VehicleParams &p = m.params();
	const BodyState &x = m.state();
	const RotorOutputs o = m.rotor_outputs(x, m.t());
	const Eigen::Vector3d a = m.acceleration(o);
	octo::truth_t msg;
	msg.utime = static_cast<int64_t>(std::llround(m.clock() * 1e6));
	msg.frame = static_cast<int64_t>(frame);
	msg.t = m.clock();
	for (int i = 0; i < 3; i++) {
		msg.pos_i[i] = x.r(i);
		msg.vel_i[i] = x.v(i);
		msg.acc_i[i] = a(i);
		msg.rate_b[i] = x.w(i);
		msg.torque_b[i] = o.torque_b(i);
		msg.inertia[i] = p.inertia[static_cast<size_t>(i)];
	}
	msg.q_i2b[0] = x.q.w();
	msg.q_i2b[1] = x.q.x();
	msg.q_i2b[2] = x.q.y();
	msg.q_i2b[3] = x.q.z();
	{
		const Eigen::Matrix3d D = Eigen::Vector3d(1, -1, -1).asDiagonal();
		const Eigen::Matrix3d R = D * x.q.toRotationMatrix() * D;
		const double k = 180.0 / M_PI;
		msg.euler_deg[0] = std::atan2(R(2, 1), R(2, 2)) * k;
		msg.euler_deg[1] = std::asin(std::max(-1.0, std::min(1.0, -R(2, 0)))) * k;
		double h = std::atan2(R(1, 0), R(0, 0)) * k;
		msg.euler_deg[2] = h < 0 ? h + 360.0 : h;
	}
	msg.on_ground = m.on_ground();
	const double d = drift_factor(p, m.t());
	for (int j = 0; j < kRotors; j++) {
		msg.throttle_cmd[j] = m.last_command()[static_cast<size_t>(j)];
		msg.s[j] = x.s[static_cast<size_t>(j)];
		msg.thrust[j] = o.thrust[static_cast<size_t>(j)];
		msg.torque[j] = o.torque[static_cast<size_t>(j)];
		msg.rotor_scale[j] = m.effect(j, m.t());
	}
	msg.force_total = o.force;
	msg.mass = p.mass;
	msg.g = p.g;
	msg.arm_length = p.arm_length;
	msg.kf = p.kf * d;
	msg.ktau = p.ktau * d;
	msg.motor_tau = p.motor_tau;
	msg.delay = p.delay;

	if (d_->lcm) {
		d_->lcm->publish(kChannel, &msg);
		return;
	}
	const int n = msg.getEncodedSize();
	d_->buf.resize(static_cast<size_t>(n));
	msg.encode(d_->buf.data(), 0, n);
	lcm_eventlog_event_t ev;
	ev.eventnum = d_->eventnum++;
	ev.timestamp = msg.utime;
	ev.channellen = static_cast<int32_t>(sizeof kChannel - 1);
	ev.datalen = n;
	ev.channel = const_cast<char *>(kChannel);
	ev.data = d_->buf.data();
	lcm_eventlog_write_event(d_->log, &ev);
}

} // namespace sim
