/*
 * peakrss.c - a child's own peak memory and CPU time, for `make bench`.
 *
 * Usage: peakrss PROGRAM [ARGS...]
 * Runs PROGRAM with its standard streams, waits for it and appends one line to
 * stderr:
 *   peakrss: peak_rss_kb N cpu_s S status C
 * then exits with PROGRAM's exit status (128 + signal if killed, 127 if it could not
 * be started).
 *
 * Why a harness: a child of the Python bench inherits the interpreter's peak RSS (the
 * kernel carries the peak of the memory image that execve replaces, and wait4 reports
 * it), so ru_maxrss from Python reads the size of Python. Forked from this small
 * process, PROGRAM's ru_maxrss is its own (at least this harness's few hundred kB).
 */
#define _DEFAULT_SOURCE /* wait4 */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

int main(int argc, char **argv)
{
	if (argc < 2 || !strcmp(argv[1], "--help")) {
		fprintf(stderr,
			"usage: peakrss PROGRAM [ARGS...]  (runs PROGRAM; its peak RSS and CPU time on stderr)\n");
		return argc < 2 ? 2 : 0;
	}
	pid_t pid = fork();
	if (pid < 0) {
		fprintf(stderr, "peakrss: fork: %s\n", strerror(errno));
		return 127;
	}
	if (pid == 0) {
		execvp(argv[1], argv + 1);
		fprintf(stderr, "peakrss: cannot run %s: %s\n", argv[1], strerror(errno));
		_exit(127);
	}
	int status = 0;
	struct rusage ru;
	while (wait4(pid, &status, 0, &ru) < 0) {
		if (errno != EINTR) {
			fprintf(stderr, "peakrss: wait4: %s\n", strerror(errno));
			return 127;
		}
	}
	int code = WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : 127;
	double cpu = (double)ru.ru_utime.tv_sec + (double)ru.ru_utime.tv_usec * 1e-6 + (double)ru.ru_stime.tv_sec +
		     (double)ru.ru_stime.tv_usec * 1e-6;
	fprintf(stderr, "peakrss: peak_rss_kb %ld cpu_s %.6f status %d\n", ru.ru_maxrss, cpu, code);
	return code;
}
