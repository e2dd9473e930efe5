/* octo-fw entry point (placeholder until the app lands: parses its flags only). */
#include <stdio.h>
#include <string.h>

int main(int argc, char **argv)
{
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--help")) {
			printf("usage: octo-fw [options]\n");
			return 0;
		}
		fprintf(stderr, "octo-fw: unknown option '%s' (see --help)\n", argv[i]);
		return 2;
	}
	return 0;
}
