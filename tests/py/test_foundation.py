"""The build foundation: binaries exist, answer --help, and the fixtures clean up."""

import subprocess

from conftest import BUILD, REPO, binary


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
    p = launch("octo-sim", "--help")
    p.wait(timeout=5)
    q = launch("octo-fw", "--help")
    q.wait(timeout=5)
    assert port() != port()
