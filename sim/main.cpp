// octo-sim entry point (placeholder until the simulator lands: parses its flags only).
#include <cstdio>
#include <cstring>

int main(int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		if (!std::strcmp(argv[i], "--help")) {
			std::printf("usage: octo-sim [options]\n");
			return 0;
		}
		std::fprintf(stderr, "octo-sim: unknown option '%s' (see --help)\n", argv[i]);
		return 2;
	}
	return 0;
}
