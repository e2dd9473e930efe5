"""octo-fw seen by MAVSDK (the pinned native `mavsdk` package): telemetry, health,
parameters, actions and status lines (a long one in chunks), as MAVSDK's own examples use them. octo-sim runs in real
time (not lockstep) so that the flight unfolds at the pace MAVSDK expects. Every
wait has a deadline."""

import json
import math
import subprocess
import time

import pytest

from conftest import binary
from test_fw_rig import Rig

mavsdk = pytest.importorskip("mavsdk")
from mavsdk.plugins.action import Action  # noqa: E402
from mavsdk.plugins.mavlink_direct.mavlink_direct import MavlinkDirect, MavlinkMessage  # noqa: E402
from mavsdk.plugins.param import Param  # noqa: E402
from mavsdk.plugins.telemetry import LandedState, Telemetry  # noqa: E402

ORIGIN = (45.5, 7.25, 300.0)   # lat, lon, field elevation MSL of the test vehicle


def poll(fn, pred, timeout, what):
    """fn() until pred(value) holds; the last value, or a failure naming `what`."""
    deadline = time.monotonic() + timeout
    v = fn()
    while not pred(v):
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout} s (last: {v})")
        time.sleep(0.05)
        v = fn()
    return v


@pytest.fixture
def vehicle(launch, port, tmp_path):
    veh = tmp_path / "vehicle.json"
    veh.write_text(json.dumps({"origin": list(ORIGIN)}))
    rig = Rig(launch, port, tmp_path)
    rig.start_sim("--vehicle", veh, "--computer-name", "octo-mavsdk-test", lockstep=False)
    rig.start_fw()
    m = mavsdk.Mavsdk(mavsdk.Configuration.create_with_component_type(mavsdk.ComponentType.GROUND_STATION))
    assert m.add_any_connection(f"udpin://127.0.0.1:{rig.gcs_port}") == mavsdk.ConnectionResult.SUCCESS
    system = m.first_autopilot(10.0)
    assert system is not None, "MAVSDK found no autopilot within 10 s"
    yield rig, system
    m.destroy()


def test_mavsdk_telemetry_health_parameters_and_flight(vehicle):
    rig, system = vehicle
    tel, act, par = Telemetry(system), Action(system), Param(system)

    # health as MAVSDK's examples wait for it
    h = poll(tel.health, lambda h: h.is_global_position_ok and h.is_home_position_ok and h.is_armable,
             15.0, "health: global position, home and armable")
    assert h.is_gyrometer_calibration_ok and h.is_accelerometer_calibration_ok
    assert h.is_local_position_ok and tel.health_all_ok()

    # position, home, attitude, heading, landed state
    pos = poll(tel.position, lambda p: abs(p.latitude_deg - ORIGIN[0]) < 1e-4, 5.0, "position")
    assert pos.longitude_deg == pytest.approx(ORIGIN[1], abs=1e-4)
    assert pos.absolute_altitude_m == pytest.approx(ORIGIN[2], abs=0.5)
    assert pos.relative_altitude_m == pytest.approx(0.0, abs=0.3)
    home = tel.home()
    assert (home.latitude_deg, home.longitude_deg) == pytest.approx(ORIGIN[:2], abs=1e-4)
    assert home.absolute_altitude_m == pytest.approx(ORIGIN[2], abs=0.5)
    att = tel.attitude_euler()
    assert abs(att.roll_deg) < 3 and abs(att.pitch_deg) < 3
    hdg = tel.heading().heading_deg
    assert min(hdg, 360.0 - hdg) < 3.0                     # the vehicle starts facing north
    tel.set_rate_landed_state(2.0)     # SET_MESSAGE_INTERVAL(EXTENDED_SYS_STATE); raises unless accepted
    tel.set_rate_position(10.0)
    poll(tel.landed_state, lambda s: s == LandedState.ON_GROUND, 5.0, "landed state on ground")
    assert not tel.in_air()
    assert tel.gps_info().fix_type >= 3                     # a 3D fix
    # no battery is simulated: BATTERY_STATUS with MAVLink's "unknown" values replaces the
    # 65.535 V MAVSDK makes of SYS_STATUS's "unknown" voltage
    bat = poll(tel.battery, lambda b: not math.isclose(b.voltage_v, 65.535, abs_tol=1e-3), 5.0, "battery")
    assert bat.voltage_v == 0.0

    # parameters: all of them, and a write read back
    n_params = len(json.loads(subprocess.run([str(binary("octo-fw")), "--dump-params"],
                                             capture_output=True, text=True, timeout=10).stdout)["params"])
    allp = par.get_all_params()
    assert len(allp.float_params) + len(allp.int_params) == n_params
    par.set_param_float("NAV_TKO_ALT", 4.0)
    assert par.get_param_float("NAV_TKO_ALT") == pytest.approx(4.0)

    # arm, take off, land
    act.set_takeoff_altitude(3.0)
    act.arm()
    poll(tel.armed, bool, 5.0, "armed")
    act.takeoff()
    poll(tel.landed_state, lambda s: s == LandedState.TAKING_OFF, 5.0, "landed state taking off")
    poll(tel.in_air, bool, 15.0, "in_air")
    poll(lambda: tel.position().relative_altitude_m, lambda z: z > 2.5, 20.0, "relative altitude 2.5 m")
    poll(tel.landed_state, lambda s: s == LandedState.IN_AIR, 20.0, "landed state in air (holding)")

    # a status line longer than STATUSTEXT's 50 characters reaches MAVSDK whole (its chunks
    # joined): the refusal of an experiment without excitation, sent as a raw COMMAND_LONG
    texts = []
    tel.subscribe_status_text(lambda st, _ud: texts.append(st.text))
    par.set_param_float("ID_EXC_AMP", 0.0)
    user_1 = MavlinkMessage(message_name="COMMAND_LONG", system_id=255, component_id=190,
                            target_system_id=1, target_component_id=1, fields_json=json.dumps(
                                {"target_system": 1, "target_component": 1, "command": 31010,
                                 "confirmation": 0, "param1": 1, "param2": 0, "param3": 0,
                                 "param4": 0, "param5": 0, "param6": 0, "param7": 0}))
    direct = MavlinkDirect(system)

    def refusal():
        direct.send_message(user_1)
        time.sleep(0.5)
        return [t for t in texts if t.startswith("Experiment 1 refused: ID_EXC")]
    got = poll(refusal, bool, 15.0, "the experiment's refusal as a STATUSTEXT")
    assert got[-1] == "Experiment 1 refused: ID_EXC_AMP/ID_EXC_TIME not > 0", texts
    act.land()
    poll(tel.landed_state, lambda s: s in (LandedState.LANDING, LandedState.ON_GROUND), 5.0, "landing")
    poll(tel.landed_state, lambda s: s == LandedState.ON_GROUND, 30.0, "landed")
    poll(tel.armed, lambda a: not a, 10.0, "disarmed after landing")
    assert tel.position().relative_altitude_m == pytest.approx(0.0, abs=0.3)


async def first(gen, pred, timeout, what):
    """The first value of an async subscription for which pred holds, within `timeout` s."""
    import asyncio

    async def take():
        async for v in gen:
            if pred(v):
                return v
    try:
        return await asyncio.wait_for(take(), timeout)
    except asyncio.TimeoutError:
        pytest.fail(f"{what}: not within {timeout} s")
    finally:
        await gen.aclose()


def test_mavsdk_asyncio_subscriptions_and_flight(launch, port, tmp_path):
    """MAVSDK's asynchronous API as its examples write it: a subscription to home yields within
    3 s of connecting (HOME_POSITION is streamed: a subscription yields only messages that
    arrive after it starts), and position, landed state, in_air, health and flight mode are
    followed as subscriptions through arm, take-off and landing."""
    import asyncio
    from mavsdk.asyncio import Configuration, ComponentType, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    veh = tmp_path / "vehicle.json"
    veh.write_text(json.dumps({"origin": list(ORIGIN)}))
    rig = Rig(launch, port, tmp_path)
    rig.start_sim("--vehicle", veh, lockstep=False)
    rig.start_fw()

    async def fly():
        async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
            await sdk.add_any_connection(f"udpin://127.0.0.1:{rig.gcs_port}")
            system = await sdk.first_autopilot(timeout_s=10.0)
            assert system is not None, "MAVSDK found no autopilot within 10 s"
            tel, act = TelemetryAsync(system), ActionAsync(system)
            t0 = time.monotonic()
            home = await first(tel.subscribe_home(), lambda h: True, 3.0, "async for home in subscribe_home()")
            assert time.monotonic() - t0 < 3.0
            assert (home.latitude_deg, home.longitude_deg) == pytest.approx(ORIGIN[:2], abs=1e-4)
            assert home.absolute_altitude_m == pytest.approx(ORIGIN[2], abs=0.5)
            await first(tel.subscribe_health(),
                        lambda h: h.is_global_position_ok and h.is_home_position_ok and h.is_armable,
                        15.0, "health")
            pos = await first(tel.subscribe_position(), lambda p: True, 3.0, "position")
            assert pos.latitude_deg == pytest.approx(ORIGIN[0], abs=1e-4)
            assert pos.relative_altitude_m == pytest.approx(0.0, abs=0.3)
            await first(tel.subscribe_landed_state(), lambda s: s == LandedState.ON_GROUND, 5.0, "on ground")
            assert await first(tel.subscribe_in_air(), lambda a: True, 5.0, "in_air") is False
            mode0 = await first(tel.subscribe_flight_mode(), lambda m: True, 5.0, "flight mode")

            await act.set_takeoff_altitude(3.0)
            await act.arm()
            await first(tel.subscribe_armed(), bool, 5.0, "armed")
            await act.takeoff()
            await first(tel.subscribe_in_air(), bool, 15.0, "in_air")
            await first(tel.subscribe_position(), lambda p: p.relative_altitude_m > 2.5, 20.0, "at 2.5 m")
            await first(tel.subscribe_landed_state(), lambda s: s == LandedState.IN_AIR, 20.0, "in air")
            # MAVSDK maps HEARTBEAT.custom_mode with PX4's tables only for PX4 autopilots: for a
            # generic one the subscription yields, but not the mode's name (CURRENT_MODE has it)
            held = await first(tel.subscribe_flight_mode(), lambda m: True, 5.0, "flight mode in flight")
            await act.land()
            await first(tel.subscribe_landed_state(), lambda s: s == LandedState.ON_GROUND, 30.0, "landed")
            await first(tel.subscribe_armed(), lambda a: not a, 10.0, "disarmed")
            return mode0, held

    mode0, held = asyncio.run(fly())
    print("flight modes seen by MAVSDK:", mode0, held)
