/*
 * param_file.c - parameter storage in a text file (hal_param_store / _fetch).
 *
 * Atomic replacement: the new text goes to FILE.tmp in the same directory,
 * is fsync'ed, renamed over FILE, and the directory is fsync'ed, so a crash at
 * any moment leaves either the complete old or the complete new file.
 */
#include "host.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "hal.h"

static char param_path[4096];

void param_file_set_path(const char *path)
{
	snprintf(param_path, sizeof param_path, "%s", path ? path : "");
}

static int write_all(int fd, const char *p, size_t n)
{
	while (n) {
		ssize_t w = write(fd, p, n);
		if (w < 0) {
			if (errno == EINTR)
				continue;
			return -1;
		}
		p += w;
		n -= (size_t)w;
	}
	return 0;
}

int hal_param_store(const char *text, size_t len)
{
	if (!param_path[0]) {
		hal_report("params: not saved (no --params FILE)");
		return -1;
	}
	char tmp[sizeof param_path + 8];
	snprintf(tmp, sizeof tmp, "%s.tmp", param_path);
	int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
	if (fd < 0) {
		hal_report("params: cannot create %s: %s", tmp, strerror(errno));
		return -1;
	}
	static const char head[] = "# octo-fw parameters: NAME VALUE (MAVProxy format)\n";
	if (write_all(fd, head, sizeof head - 1) || write_all(fd, text, len) || fsync(fd)) {
		hal_report("params: cannot write %s: %s", tmp, strerror(errno));
		close(fd);
		unlink(tmp);
		return -1;
	}
	if (close(fd) || rename(tmp, param_path)) {
		hal_report("params: cannot replace %s: %s", param_path, strerror(errno));
		unlink(tmp);
		return -1;
	}
	char dir[sizeof param_path];
	snprintf(dir, sizeof dir, "%s", param_path);
	int dfd = open(dirname(dir), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (dfd >= 0) {
		(void)fsync(dfd);
		close(dfd);
	}
	return 0;
}

long hal_param_fetch(char *buf, size_t cap)
{
	if (!param_path[0] || cap == 0)
		return -1;
	int fd = open(param_path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return -1;
	size_t n = 0;
	while (n + 1 < cap) {
		ssize_t r = read(fd, buf + n, cap - 1 - n);
		if (r < 0) {
			if (errno == EINTR)
				continue;
			close(fd);
			return -1;
		}
		if (r == 0)
			break;
		n += (size_t)r;
	}
	close(fd);
	if (n + 1 >= cap)
		hal_report("params: %s longer than %zu bytes, rest ignored", param_path, cap - 1);
	buf[n] = 0;
	return (long)n;
}
