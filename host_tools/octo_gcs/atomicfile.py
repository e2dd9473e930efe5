"""Files that appear only complete: the one atomic-write helper of octo_gcs."""

import os
import tempfile


def file_mode():
    """0666 minus the umask: what open() would give (mkstemp makes 0600 files)."""
    um = os.umask(0)
    os.umask(um)
    return 0o666 & ~um


def atomic_write(path, text, mode="w"):
    """Write `text` to `path` so that the file is either the complete old or the complete new
    version: a temporary file in the same directory, fsync, the usual permissions, rename,
    then fsync of the directory."""
    path = os.fspath(path)
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=d)
    try:
        with os.fdopen(fd, mode) as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    dfd = os.open(d, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)
