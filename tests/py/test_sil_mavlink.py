"""octo-sil --mavlink-listen: MAVLink served as by octo-fw, so a ground station can watch and
fly an in-process run (heartbeats, parameters, commands over UDP)."""

import os
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from conftest import wait_until  # noqa: E402


def test_ground_station_watches_an_in_process_script(launch, port, tmp_path):
    mav, gcs_port = port(), port()
    conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{gcs_port}", source_system=255, dialect="common")
    try:
        # a long hover: seconds of wall time at thousands of times real time
        sil = launch("octo-sil", "--mavlink-listen", mav, "--gcs", f"127.0.0.1:{gcs_port}",
                     "--params", tmp_path / "p.parm",
                     "--script", "arm; takeoff 5; wait hold; sleep 6000; land; wait disarmed")
        hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
        assert hb is not None, "no heartbeat"
        assert hb.type == mavutil.mavlink.MAV_TYPE_OCTOROTOR

        def holding():
            m = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
            return m is not None and m.custom_mode == 3
        assert wait_until(holding, timeout=20, step=0.0), "never saw the vehicle hold"
        # the ground station's own requests are served too
        conn.mav.param_request_read_send(1, 1, b"VEH_KF", -1)
        pv = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=5,
                             condition="PARAM_VALUE.param_id == 'VEH_KF'")
        assert pv is not None
        # telemetry in wall-clock time: a few heartbeats per second, not one per simulated second
        t0, n = time.monotonic(), 0
        while time.monotonic() - t0 < 1.0 and sil.alive():
            if conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.2):
                n += 1
        assert n <= 5, f"{n} heartbeats in one wall second"
        assert sil.wait(timeout=120) == 0
    finally:
        conn.close()
