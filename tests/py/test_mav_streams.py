"""Every stream of docs/mavlink.md's telemetry table answers MAVLink's message-interval protocol:
MAV_CMD_GET_MESSAGE_INTERVAL gives its default interval in MESSAGE_INTERVAL (-1: only on
change and on request), MAV_CMD_SET_MESSAGE_INTERVAL -1 stops it, 0 restores the default,
a number sets it, and MAV_CMD_REQUEST_MESSAGE sends it at once. The table is read from the
documentation, so the documentation and the firmware cannot drift apart; a periodic message
the firmware sends that the table lacks fails the test too. Every wait has a deadline."""

import re
import time

import pytest

from conftest import REPO
from octo_gcs import link
from test_fw_rig import Rig

M = link.mavlink
# sent by the endpoint outside the telemetry table (answers, events, the parameter protocol)
NOT_STREAMS = {"COMMAND_ACK", "STATUSTEXT", "PARAM_VALUE", "MESSAGE_INTERVAL", "AUTOPILOT_VERSION",
               "AVAILABLE_MODES", "MISSION_COUNT", "FILE_TRANSFER_PROTOCOL", "COMPONENT_METADATA",
               "COMPONENT_INFORMATION"}


def table():
    """[(message name, default interval in us or -1, only while an experiment runs)] from the
    telemetry table of docs/mavlink.md"""
    text = (REPO / "docs" / "mavlink.md").read_text()
    rows = []
    for m in re.finditer(r"^\| ([A-Z_0-9]+) \| (\d+) \| ([^|]+) \|([^|]*)\|", text, re.M):
        name, msgid, rate, note = m.group(1), int(m.group(2)), m.group(3).strip(), m.group(4)
        assert getattr(M, f"MAVLINK_MSG_ID_{name}") == msgid, name
        if rate.endswith(" Hz"):
            us = round(1e6 / float(rate[:-3]))
        else:
            assert rate == "on change, on request", rate
            us = -1
        rows.append((name, us, "experiment" in note))
    assert len(rows) >= 15, rows
    return rows


@pytest.fixture
def rig(launch, port, tmp_path):
    r = Rig(launch, port, tmp_path)
    r.start_sim(lockstep=False)
    r.start_fw()
    r.connect()
    deadline = time.monotonic() + 10
    while r.recv({"HOME_POSITION"}, timeout=0.5) is None:   # a position, so every stream exists
        assert time.monotonic() < deadline, "no HOME_POSITION within 10 s"
    return r


def interval(rig, msgid):
    rig.m.mav.command_long_send(1, 1, M.MAV_CMD_GET_MESSAGE_INTERVAL, 0, msgid, 0, 0, 0, 0, 0, 0)
    deadline = time.monotonic() + 3
    while time.monotonic() < deadline:
        msg = rig.recv({"MESSAGE_INTERVAL"}, timeout=deadline - time.monotonic())
        if msg is not None and msg.message_id == msgid:
            return msg.interval_us
    pytest.fail(f"no MESSAGE_INTERVAL for {msgid}")


def requested(rig, msgid, name):
    """MAV_CMD_REQUEST_MESSAGE: its result and whether the message came after the ACK."""
    rig.backlog = [m for m in rig.backlog if m.get_type() != "COMMAND_ACK"]
    rig.m.mav.command_long_send(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0, msgid, 0, 0, 0, 0, 0, 0)
    result, got, deadline = None, False, time.monotonic() + 3
    while time.monotonic() < deadline and not (result is not None and (got or result != 0)):
        msg = rig.recv({"COMMAND_ACK", name}, timeout=0.1)
        if msg is None:
            continue
        if msg.get_type() == "COMMAND_ACK" and msg.command == M.MAV_CMD_REQUEST_MESSAGE:
            result = msg.result
        elif msg.get_type() == name and result is not None:
            got = True
    return result, got


def seen(rig, name, seconds):
    """How many `name` messages arrive within `seconds`."""
    n, deadline = 0, time.monotonic() + seconds
    while time.monotonic() < deadline:
        if rig.recv({name}, timeout=deadline - time.monotonic()) is not None:
            n += 1
    return n


def test_every_stream_answers_the_message_interval_protocol(rig):
    rows = table()
    for name, us, experiment_only in rows:
        msgid = getattr(M, f"MAVLINK_MSG_ID_{name}")
        assert interval(rig, msgid) == us, name
        # REQUEST_MESSAGE: one now (the live estimates exist only in an experiment)
        r, got = requested(rig, msgid, name)
        if experiment_only:
            assert r == M.MAV_RESULT_TEMPORARILY_REJECTED, name
        else:
            assert r == M.MAV_RESULT_ACCEPTED and got, name
        # off, then the default again, then a rate of our own
        assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, -1)[0] == M.MAV_RESULT_ACCEPTED, name
        assert interval(rig, msgid) == -1, name
        if us > 0 and not experiment_only:
            seen(rig, name, 0.2)   # in flight before the change
            assert seen(rig, name, max(1.5 * us * 1e-6, 0.5)) == 0, f"{name} still sent when off"
        assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, 0)[0] == M.MAV_RESULT_ACCEPTED, name
        assert interval(rig, msgid) == us, name
        assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, 250000)[0] == M.MAV_RESULT_ACCEPTED, name
        assert interval(rig, msgid) == 250000, name
        if not experiment_only:
            assert seen(rig, name, 1.1) >= 3, f"{name} not at 4 Hz"
        assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, 0)[0] == M.MAV_RESULT_ACCEPTED, name
    # a message the vehicle does not have: "not available", and no interval to set
    assert interval(rig, M.MAVLINK_MSG_ID_SCALED_PRESSURE) == 0
    assert rig.cmd(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_SCALED_PRESSURE, 0)[0] == \
        M.MAV_RESULT_UNSUPPORTED


def test_the_table_names_every_periodic_message(rig):
    names = {name for name, _, _ in table()}
    got, deadline = set(), time.monotonic() + 2.5
    while time.monotonic() < deadline:
        msg = rig.m.recv_match(blocking=True, timeout=0.1)
        if msg is not None:
            got.add(msg.get_type())
    got -= NOT_STREAMS | {"BAD_DATA"}
    assert got <= names, got - names
    assert {"HEARTBEAT", "HOME_POSITION", "LOCAL_POSITION_NED", "GLOBAL_POSITION_INT"} <= got
