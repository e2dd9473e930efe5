/*
 * param_file.c - parameter storage in a text file (the host's param_store / _fetch).
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

void param_file_set_path(struct param_file *pf, const char *path)
{
	snprintf(pf->path, sizeof pf->path, "%s", path ? path : "");
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

int param_file_store(const struct param_file *pf, const char *text, size_t len)
{
	if (!pf->path[0]) {
		host_report("params: not saved (no --params FILE)");
		return -1;
	}
	char tmp[sizeof pf->path + 8];
	snprintf(tmp, sizeof tmp, "%s.tmp", pf->path);
	int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
	if (fd < 0) {
		host_report("params: cannot create %s: %s", tmp, strerror(errno));
		return -1;
	}
	static const char head[] = "# octo-fw parameters: NAME VALUE (MAVProxy format)\n";
	if (write_all(fd, head, sizeof head - 1) || write_all(fd, text, len) || fsync(fd)) {
		host_report("params: cannot write %s: %s", tmp, strerror(errno));
		close(fd);
		unlink(tmp);
		return -1;
	}
	if (close(fd) || rename(tmp, pf->path)) {
		host_report("params: cannot replace %s: %s", pf->path, strerror(errno));
		unlink(tmp);
		return -1;
	}
	char dir[sizeof pf->path];
	snprintf(dir, sizeof dir, "%s", pf->path);
	int dfd = open(dirname(dir), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
	if (dfd >= 0) {
		(void)fsync(dfd);
		close(dfd);
	}
	return 0;
}

long param_file_fetch(const struct param_file *pf, char *buf, size_t cap)
{
	if (!pf->path[0] || cap == 0)
		return -1;
	int fd = open(pf->path, O_RDONLY | O_CLOEXEC);
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
		host_report("params: %s longer than %zu bytes, rest ignored", pf->path, cap - 1);
	buf[n] = 0;
	return (long)n;
}
