"""octo-sim seen by a third-party X-Plane UDP client (pyxpudpserver, pinned) and by
the beacon's own layout: BECN, DATA, RREF, DREF, CMND and the OpenGL origin at sea
level. Every wait has a deadline."""

import json
import socket
import struct
import time
import uuid

import pytest

from conftest import wait_until

pyxp = pytest.importorskip("pyxpudpserver.XPlaneUDPServer")

GROUP, BECN_PORT = "239.255.1.1", 49707


def beacon_socket():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    s.bind(("", BECN_PORT))
    try:
        s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                     socket.inet_aton(GROUP) + socket.inet_aton("0.0.0.0"))
    except OSError as e:   # no route to the group: nothing on this host can hear a beacon
        s.close()
        pytest.skip(f"this host cannot join multicast {GROUP}: {e}")
    s.settimeout(0.2)
    return s


def next_beacon(sock, name, timeout):
    """The next BECN whose computer name is `name` (other octo-sims may run in
    parallel), as (datagram, source address), or None after `timeout` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            d, src = sock.recvfrom(2048)
        except socket.timeout:
            continue
        if d[:5] == b"BECN\0" and d[21:].split(b"\0")[0] == name.encode():
            return d, src
    return None


def unique_name():
    return "octo-test-" + uuid.uuid4().hex[:10]


@pytest.mark.parametrize("version", [11, 12])
def test_beacon_layout(launch, port, version):
    xp_port, name = port(), unique_name()
    sock = beacon_socket()
    try:
        launch("octo-sim", "--xp-port", xp_port, "--data-out", f"127.0.0.1:{port()}",
               "--xplane-version", version, "--computer-name", name)
        got = next_beacon(sock, name, 5.0)
        assert got, "no BECN from octo-sim within 5 s"
        d, src = got
        major, minor, host, number, role, rx_port = struct.unpack("<BBiiIH", d[5:21])
        assert (major, host, role, rx_port) == (1, 1, 1, xp_port)
        rest = d[21:]
        assert rest[:len(name) + 1] == name.encode() + b"\0"
        if version == 12:
            assert (minor, number) == (2, 120100)
            assert len(rest) == len(name) + 3
            assert struct.unpack("<H", rest[-2:])[0] == 49010   # RakNet port after the name
        else:
            assert (minor, number) == (1, 115500)
            assert len(rest) == len(name) + 1
        # once a second: a second one follows
        assert next_beacon(sock, name, 3.0), "the beacon is not repeated"
    finally:
        sock.close()


def test_no_beacon_flag(launch, port):
    name = unique_name()
    sock = beacon_socket()
    try:
        sim = launch("octo-sim", "--xp-port", port(), "--data-out", f"127.0.0.1:{port()}",
                     "--no-beacon", "--computer-name", name)
        assert next_beacon(sock, name, 2.5) is None
        sim.stop()
        counters = json.loads(sim.stderr_path.read_text().split("counters ", 1)[1].splitlines()[0])
        assert counters["tx_beacon"] == 0 and counters["tx_beacon_error"] == 0
    finally:
        sock.close()


def test_beacon_without_multicast_route_is_counted_not_fatal(tmp_path):
    """In a network namespace with only the loopback up there is no route to the
    group: every beacon fails, the simulator runs on and counts the failures."""
    import shutil
    import subprocess

    from conftest import binary
    unshare = shutil.which("unshare")
    if not unshare or subprocess.run([unshare, "-n", "true"], capture_output=True).returncode != 0:
        pytest.skip("needs unshare -n (a network namespace) to take the multicast route away")
    sim = binary("octo-sim")
    r = subprocess.run([unshare, "-n", "sh", "-c",
                        f'ip link set lo up && exec "{sim}" --bind 0.0.0.0 --rows 1 --rate 20 --duration 2.5'],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    counters = json.loads(r.stderr.split("counters ", 1)[1].splitlines()[0])
    assert counters["tx_beacon"] == 0 and counters["tx_beacon_error"] >= 2, counters
    assert counters["tx_data"] >= 40, counters


@pytest.fixture
def client():
    srv = pyxp.XPlaneUDPServer()
    srv.daemon = True        # never keeps pytest alive
    yield srv
    srv.quit()


def vehicle(tmp_path, name, alt):
    p = tmp_path / f"{name}.json"
    p.write_text(json.dumps({"origin": [45.0, 7.5, alt]}))
    return p


def test_pyxpudpserver_reads_data_rref_sets_dref_and_follows_the_beacon(launch, port, tmp_path, client):
    xp_port, data_port, name = port(), port(), unique_name()
    sim_args = ["--xp-port", xp_port, "--data-out", f"127.0.0.1:{data_port}", "--rows", "17,20,21",
                "--rate", "30", "--xplane-version", "12", "--computer-name", name]
    beacon_socket().close()   # skips where multicast cannot be joined (the library needs it)
    sim = launch("octo-sim", *sim_args, "--vehicle", vehicle(tmp_path, "a", 300.0))
    client.initialiseUDP(("127.0.0.1", data_port), ("127.0.0.1", xp_port), name)
    client.start()

    # the beacon: the library sees "its" X-Plane, with the version number
    assert wait_until(lambda: client.XPalive, 5.0), client.statusMsg
    assert "Version: 120100" in client.statusMsg

    # DATA rows 20 (lat, lon, ft MSL) and 21 (OpenGL, origin at sea level: y = elevation)
    assert wait_until(lambda: client.getData((20, 0)) != 0, 5.0)
    assert client.getData((20, 0)) == pytest.approx(45.0, abs=1e-4)
    assert client.getData((20, 1)) == pytest.approx(7.5, abs=1e-4)
    assert client.getData((20, 2)) == pytest.approx(300.0 / 0.3048, abs=1.0)
    assert client.getData((21, 1)) == pytest.approx(300.0, abs=0.5)
    assert client.getData((17, 2)) == pytest.approx(0.0, abs=2.0) or client.getData((17, 2)) > 358.0

    # RREF (one socket per dataref in this library), and DREF read back through RREF
    local_y = "sim/flightmodel/position/local_y"
    thro0 = "sim/flightmodel/engine/ENGN_thro_use[0]"
    client.getData(local_y)
    client.getData(thro0)
    assert wait_until(lambda: abs(client.getData(local_y) - 300.0) < 0.5, 5.0), client.getData(local_y)
    client.sendXPDref("sim/flightmodel/engine/ENGN_thro_use", 0, value=0.25)
    assert wait_until(lambda: client.getData(thro0) == 0.25, 5.0), client.getData(thro0)

    # CMND as the library sends it (no trailing NUL) is accepted
    client.sendXPCmd("sim/operation/pause_toggle")

    # restart: the library notices the beacon's absence, then re-subscribes its RREFs
    # when it reappears; the new simulator has another field elevation
    sim.stop()
    counters = json.loads(sim.stderr_path.read_text().split("counters ", 1)[1].splitlines()[0])
    assert counters["rx_cmnd"] == 1 and counters["rx_unterminated"] == 0
    assert counters["tx_beacon"] >= 1
    assert wait_until(lambda: not client.XPalive, 6.0), "the library never saw X-Plane go away"
    launch("octo-sim", *sim_args, "--vehicle", vehicle(tmp_path, "b", 500.0))
    assert wait_until(lambda: client.XPalive, 5.0), client.statusMsg
    assert wait_until(lambda: abs(client.getData(local_y) - 500.0) < 0.5, 5.0), client.getData(local_y)


def test_fw_finds_xplane_by_its_beacon(tmp_path):
    """octo-fw --xplane auto takes X-Plane's host and port from the first beacon and
    says which X-Plane it found; then the link works (the version is read back).
    Run in a private network namespace, where no other simulator's beacon arrives."""
    import shutil
    import subprocess

    from conftest import binary
    unshare = shutil.which("unshare")
    if not unshare or subprocess.run([unshare, "-n", "true"], capture_output=True).returncode != 0:
        pytest.skip("needs unshare -n (a private network namespace)")
    sim, fw, log = binary("octo-sim"), binary("octo-fw"), tmp_path / "fw.stderr"
    script = (
        "ip link set lo up && ip route add 224.0.0.0/4 dev lo && "
        f'{{ "{sim}" --xp-port 47300 --data-out 127.0.0.1:47301 --computer-name beacon-test '
        "--xplane-version 11 --duration 4 2>/dev/null & } && "
        f'{{ "{fw}" --xplane auto --xp-listen 47301 --mavlink-listen 47302 --gcs 127.0.0.1:47303 '
        f'2>"{log}" & }} && FW=$! && wait %1; kill -TERM $FW; wait $FW')
    r = subprocess.run([unshare, "-n", "sh", "-c", script], capture_output=True, text=True, timeout=30)
    out = log.read_text() if log.exists() else ""
    assert r.returncode == 0, (r.stderr, out)
    assert 'found X-Plane 11.55.0 (beacon 1.1) on "beacon-test" at 127.0.0.1:47300' in out, out
    assert "X-Plane version 115500" in out, out


def test_fw_auto_without_beacon_says_why(tmp_path):
    import shutil
    import subprocess

    from conftest import binary
    unshare = shutil.which("unshare")
    if not unshare or subprocess.run([unshare, "-n", "true"], capture_output=True).returncode != 0:
        pytest.skip("needs unshare -n (a private network namespace)")
    r = subprocess.run([unshare, "-n", "sh", "-c", "ip link set lo up && ip route add 224.0.0.0/4 dev lo && "
                        f'exec "{binary("octo-fw")}" --xplane auto --xp-listen 47301'],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 1
    assert "no X-Plane beacon within 30 s" in r.stderr, r.stderr
