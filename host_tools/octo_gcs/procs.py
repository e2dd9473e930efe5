"""Starting and always stopping the project's programs (octo-sim, octo-fw).

The build directory is found from --build-dir, else the OCTO_BUILD environment
variable, else ``build/`` of the repository this package lives in (``make``
installs it in editable mode). Every child gets its own process group and a
parent-death signal (Linux), so that neither Ctrl-C in the terminal nor the
death of octo-gcs leaves a simulator running; `Proc.stop` sends SIGTERM, then
SIGKILL.
"""

import os
import signal
import socket
import subprocess
import time
from pathlib import Path

from .base import GcsError

REPO = Path(__file__).resolve().parents[2]


def build_dir(option=None):
    """The directory holding octo-sim and octo-fw (checked)."""
    if option:
        d, why = Path(option), "--build-dir"
    elif os.environ.get("OCTO_BUILD"):
        d, why = Path(os.environ["OCTO_BUILD"]), "OCTO_BUILD"
    else:
        d, why = REPO / "build", "the repository's build/"
    for name in ("octo-sim", "octo-fw"):
        if not os.access(d / name, os.X_OK):
            raise GcsError(f"{d / name} not found ({why}): run `make` first, or give --build-dir")
    return d


def free_udp_port():
    """A UDP port on 127.0.0.1 that is free now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _child_setup():
    """In the child before exec: own process group, SIGTERM when the parent dies."""
    os.setpgrp()
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except Exception:
        pass


class Proc:
    """A running program in its own process group; stdout goes to log_path, stderr to the
    same file or, when given, to stderr_path. octo-gcs and the pytest fixtures use it."""

    def __init__(self, argv, log_path, name, stderr_path=None, env=None):
        self.name = name
        self.argv = [str(a) for a in argv]
        self.log_path = Path(log_path)
        self.stderr_path = Path(stderr_path) if stderr_path else None
        self._log = open(self.log_path, "wb")
        self._err = open(self.stderr_path, "wb") if self.stderr_path else None
        try:
            self.popen = subprocess.Popen(
                self.argv,
                stdin=subprocess.DEVNULL,
                stdout=self._log,
                stderr=self._err or subprocess.STDOUT,
                env=env,
                preexec_fn=_child_setup,
            )
        except OSError as e:
            self._close()
            raise GcsError(f"cannot start {self.argv[0]}: {e}") from None

    @property
    def pid(self):
        return self.popen.pid

    def wait(self, timeout=None):
        return self.popen.wait(timeout=timeout)

    def _close(self):
        for f in (self._log, self._err):
            if f is not None and not f.closed:
                f.close()

    def alive(self):
        return self.popen.poll() is None

    def stop(self, grace=3.0):
        """SIGTERM, then SIGKILL after `grace` s. Returns the exit status."""
        if self.popen.poll() is None:
            self._signal(signal.SIGTERM)
            try:
                self.popen.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                self._signal(signal.SIGKILL)
                self.popen.wait(timeout=5)
        self._close()
        return self.popen.returncode

    def _signal(self, sig):
        try:
            os.killpg(self.popen.pid, sig)
        except (ProcessLookupError, PermissionError):
            try:
                self.popen.send_signal(sig)
            except ProcessLookupError:
                pass

    def tail(self, n=12):
        """The last n lines of its output (for error messages)."""
        try:
            self._log.flush()
            lines = self.log_path.read_text(errors="replace").splitlines()
        except OSError:
            return ""
        return "\n".join(lines[-n:])


def stop_all(procs, grace=3.0):
    """Stops every process (SIGTERM to all first, then waits)."""
    live = [p for p in procs if p is not None]
    for p in live:
        if p.alive():
            p._signal(signal.SIGTERM)
    deadline = time.monotonic() + grace
    for p in live:
        p.stop(grace=max(0.1, deadline - time.monotonic()))


class Terminated(Exception):
    """SIGTERM or SIGHUP received: unwind and clean up like Ctrl-C."""


class signals_as_exceptions:
    """Context manager: SIGTERM/SIGHUP raise Terminated (SIGINT raises KeyboardInterrupt)."""

    def __enter__(self):
        self._old = {}
        for sig in (signal.SIGTERM, signal.SIGHUP):
            try:
                self._old[sig] = signal.signal(sig, self._raise)
            except (ValueError, OSError):  # not the main thread
                pass
        return self

    @staticmethod
    def _raise(signum, frame):
        raise Terminated(signal.Signals(signum).name)

    def __exit__(self, *exc):
        for sig, h in self._old.items():
            signal.signal(sig, h)
        return False


def exit_status(call, err=None):
    """call()'s exit status, octo-gcs's way: a GcsError is its message and 1, Ctrl-C 130,
    SIGTERM or SIGHUP 143 (signals_as_exceptions)."""
    import sys

    err = err if err is not None else sys.stderr
    try:
        return call()
    except GcsError as e:
        print(f"octo-gcs: {e}", file=err)
        return 1
    except KeyboardInterrupt:
        print("octo-gcs: interrupted", file=err)
        return 130
    except Terminated as e:
        print(f"octo-gcs: stopped by {e}", file=err)
        return 143
