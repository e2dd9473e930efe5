"""The build foundation: binaries exist, answer --help, and the fixtures clean up."""

import os
import subprocess
import time

import pytest

from conftest import BUILD, REPO, binary, wait_until


def test_binaries_answer_help():
    for name in ("octo-sim", "octo-fw"):
        r = subprocess.run([binary(name), "--help"], capture_output=True, text=True, timeout=10)
        assert r.returncode == 0, r.stderr
        assert "usage" in r.stdout.lower()


def test_bad_flag_is_a_clear_error():
    for name in ("octo-sim", "octo-fw"):
        r = subprocess.run([binary(name), "--no-such-flag"], capture_output=True, text=True, timeout=10)
        assert r.returncode == 2
        assert "--no-such-flag" in r.stderr


def test_octo_gcs_is_installed_in_the_venv():
    r = subprocess.run([REPO / ".venv" / "bin" / "octo-gcs", "--version"],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and "octo-gcs" in r.stdout


def test_generated_code_lives_in_build_only():
    assert (BUILD / "gen" / "mavlink" / "common" / "mavlink.h").exists()
    tracked = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True).stdout
    assert "mavlink_msg_" not in tracked
    assert not any(line.startswith(("build/", ".venv/")) for line in tracked.splitlines())


def test_launch_fixture_stops_processes(launch, port):
    """A long-running program is stopped for good, and ports are never handed out twice."""
    p = launch("octo-sim", "--xp-port", port(), "--data-out", f"127.0.0.1:{port()}")
    assert wait_until(lambda: p.alive(), timeout=2)
    time.sleep(0.2)
    assert p.alive(), p.stderr()
    p.stop()
    assert not p.alive()
    with pytest.raises(ProcessLookupError):
        os.killpg(p.pid, 0)          # nothing of its process group is left
    ports = {port() for _ in range(50)}
    assert len(ports) == 50
