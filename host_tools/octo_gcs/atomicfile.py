"""Files that appear only complete: the one atomic-write helper of octo_gcs."""

import contextlib
import contextvars
import os
import tempfile

_FSYNC = contextvars.ContextVar("octo_gcs_atomic_fsync", default=True)


@contextlib.contextmanager
def scratch():
    """Within it, atomic_write still renames only complete files into place but skips the
    fsyncs: for files in a scratch directory that is deleted afterwards (a campaign mission's
    directory on its worker), where durability buys nothing and costs milliseconds per file."""
    token = _FSYNC.set(False)
    try:
        yield
    finally:
        _FSYNC.reset(token)


def file_mode():
    """0666 minus the umask: what open() would give (mkstemp makes 0600 files)."""
    um = os.umask(0)
    os.umask(um)
    return 0o666 & ~um


def atomic_write(path, text, mode="w"):
    """Write `text` to `path` so that the file is either the complete old or the complete new
    version: a temporary file in the same directory, fsync, the usual permissions, rename,
    then fsync of the directory (no fsyncs within scratch())."""
    path = os.fspath(path)
    d = os.path.dirname(os.path.abspath(path))
    sync = _FSYNC.get()
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=d)
    try:
        with os.fdopen(fd, mode) as f:
            f.write(text)
            f.flush()
            if sync:
                os.fsync(f.fileno())
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    if not sync:
        return
    dfd = os.open(d, os.O_RDONLY)
    try:
        os.fsync(dfd)
    finally:
        os.close(dfd)
