"""Shared pytest fixtures: the project's binaries on free ports, always stopped.

`launch` starts a built program (``launch("octo-sim", "--lockstep", ...)``), keeps
its stdout/stderr in the test's tmp_path and stops it at the end of the test
(SIGTERM, then SIGKILL), whatever happens. `free_port()` hands out UDP ports the
kernel reports free and never hands out the same port twice in one session, so
test files can run in parallel (pytest -n) without fixed ports.
"""

import json
import os
import socket
import subprocess
import time
from pathlib import Path

import pytest
from octo_gcs.procs import Proc

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("OCTO_BUILD", REPO / "build"))

_given_ports = set()
_live = []  # every Process started in this session, for a last sweep


def free_port(kind=socket.SOCK_DGRAM) -> int:
    """A port on 127.0.0.1 that is free now (UDP by default)."""
    for _ in range(100):
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        if port not in _given_ports:
            _given_ports.add(port)
            return port
    raise RuntimeError("no free port found")


class Process(Proc):
    """A running project binary (octo-gcs's Proc) whose stdout and stderr go to NAME.stdout
    and NAME.stderr in the test's directory."""

    def __init__(self, argv, logdir: Path, name: str, env=None):
        super().__init__(argv, logdir / f"{name}.stdout", name, stderr_path=logdir / f"{name}.stderr",
                         env=env)
        self.stdout_path = self.log_path
        _live.append(self)

    def stdout(self) -> str:
        self._log.flush()
        return self.stdout_path.read_text(errors="replace")

    def stderr(self) -> str:
        self._err.flush()
        return self.stderr_path.read_text(errors="replace")


def binary(name: str) -> Path:
    path = BUILD / name
    if not path.exists():
        pytest.fail(f"{path} is not built: run `make` first")
    return path


@pytest.fixture
def launch(tmp_path):
    """Start a built binary: launch("octo-sim", "--lockstep", ...) -> Process."""
    started = []
    counts = {}

    def _launch(name, *args, env=None):
        counts[name] = counts.get(name, 0) + 1
        tag = name if counts[name] == 1 else f"{name}.{counts[name]}"
        p = Process([binary(name), *args], tmp_path, tag, env=env)
        started.append(p)
        return p

    yield _launch
    for p in reversed(started):
        p.stop()


@pytest.fixture
def port():
    """Factory of free UDP ports: port() -> int."""
    return free_port


def draw_inertia(draw):
    """Principal moments from draw() until they obey the triangle inequality (each at most the
    sum of the other two): octo-sim and octo-sil refuse a body that does not."""
    while True:
        inertia = draw()
        if all(2 * x <= sum(inertia) for x in inertia):
            return inertia


def wait_until(pred, timeout=5.0, step=0.01):
    """Poll pred() until it is true or `timeout` s pass; returns its last value."""
    deadline = time.monotonic() + timeout
    while True:
        v = pred()
        if v or time.monotonic() > deadline:
            return v
        time.sleep(step)


def pytest_sessionfinish(session, exitstatus):
    for p in _live:
        p.stop(grace=1.0)


GCS = REPO / ".venv" / "bin" / "octo-gcs"


def run_gcs(*args, timeout=120):
    """octo-gcs on the build under test (OCTO_BUILD), its output captured, no standard input."""
    env = dict(os.environ, OCTO_BUILD=str(BUILD))
    return subprocess.run([str(GCS), *map(str, args)], capture_output=True, text=True, timeout=timeout,
                          env=env, stdin=subprocess.DEVNULL)


def read_report(out):
    """A mission's report.json."""
    return json.loads((out / "report.json").read_text())
