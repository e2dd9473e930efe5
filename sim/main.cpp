// octo-sim: the paper's octocopter behind X-Plane 11/12's UDP protocol.
#include <atomic>
#include <csignal>
#include <cstring>

#include "options.hpp"
#include "server.hpp"

static std::atomic<bool> g_stop{false};

static void on_signal(int) { g_stop = true; }

int main(int argc, char **argv)
{
	sim::Options o;
	int rc = sim::parse_options(argc, argv, o);
	if (rc >= 0)
		return rc;
	struct sigaction sa;
	std::memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal; // no SA_RESTART: poll() returns on a signal
	sigaction(SIGINT, &sa, nullptr);
	sigaction(SIGTERM, &sa, nullptr);
	std::signal(SIGPIPE, SIG_IGN);
	return sim::run_server(o, g_stop);
}
