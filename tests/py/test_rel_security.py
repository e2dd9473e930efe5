"""Security: signing key files that octo-fw and octo-gcs read alike, a
signed link end to end with the octo-gcs command, wrongly signed commands
rejected and counted. (Unsigned/wrong/replayed PARAM_SET and COMMAND_LONG are in
test_fw_mavlink.py; X-Plane datagrams from a foreign host in test_fw_xplane.py
and, during a flight, in test_rel_flight.py.)"""

import hashlib
import os
import subprocess
import sys
import time

import pytest

from conftest import REPO
from test_fw_rig import Rig, mavlink

sys.path.insert(0, str(REPO / "host_tools"))
from octo_gcs.link import read_signing_key  # noqa: E402

VENV_BIN = REPO / ".venv" / "bin"

KEY_FILES = {
    "hex_newline": ("0123456789abcdef" * 4 + "\n").encode(),
    "hex_upper_spaces": ("  " + "FEDCBA9876543210" * 4 + "\r\n").encode(),
    "passphrase": b"correct horse battery staple\n",
    "passphrase_64_chars_not_hex": b"g" * 64,
    # 64 characters that bytes.fromhex would take (spaces inside) and turn into a
    # 22-byte key: a passphrase for both sides (regression, octo-gcs link.py)
    "hex_with_inner_spaces": b"ab " * 21 + b"a",
    "raw_32_bytes": bytes(range(200, 232)),
}


def expected_key(data):
    s = data.strip()
    if len(s) == 64 and all(chr(c) in "0123456789abcdefABCDEF" for c in s):
        return bytes.fromhex(s.decode())
    return hashlib.sha256(s).digest()


@pytest.mark.parametrize("name", sorted(KEY_FILES))
def test_gcs_key_rule(tmp_path, name):
    f = tmp_path / "key"
    f.write_bytes(KEY_FILES[name])
    key = read_signing_key(f)
    assert len(key) == 32 and key == expected_key(KEY_FILES[name])


def test_fw_and_gcs_agree_on_every_key_file(launch, port, tmp_path):
    """For each key file: octo-fw with --signing-key F answers a ground station whose
    key is octo-gcs's reading of F (and its signed answers verify there)."""
    from pymavlink import mavutil
    for name, data in sorted(KEY_FILES.items()):
        f = tmp_path / f"{name}.key"
        f.write_bytes(data)
        rig = Rig(launch, port, tmp_path)
        rig.start_fw("--signing-key", f)
        rig.m = mavutil.mavlink_connection(f"udpin:127.0.0.1:{rig.gcs_port}", source_system=255)
        rig.m.setup_signing(read_signing_key(f), sign_outgoing=True)
        assert rig.m.wait_heartbeat(timeout=5) is not None, name
        msg = rig.param_get("VEH_MASS", timeout=2.0)
        assert msg is not None, f"{name}: octo-fw and octo-gcs read different keys"
        rig.m.close()
        rig.fw.stop()
    # an empty key file is refused by both
    (tmp_path / "empty.key").write_bytes(b" \n")
    with pytest.raises(Exception):
        read_signing_key(tmp_path / "empty.key")
    from conftest import binary
    r = subprocess.run([binary("octo-fw"), "--signing-key", tmp_path / "empty.key"], capture_output=True,
                       text=True, timeout=10)
    assert r.returncode == 2 and "empty" in r.stderr


def gcs(*args, timeout=20):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.run([VENV_BIN / "octo-gcs", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env)


def test_octo_gcs_signed_link_end_to_end(launch, port, tmp_path):
    """octo-gcs params set/get with --signing-key against octo-fw with the same
    passphrase file; without the key, or with another one, the write does not
    happen; wrongly signed COMMAND_LONGs are not answered and are counted."""
    key = tmp_path / "pass.txt"
    key.write_text("octo-sil signing test passphrase\n")
    other = tmp_path / "other.txt"
    other.write_text("another passphrase\n")
    rig = Rig(launch, port, tmp_path)
    rig.start_fw("--signing-key", key)
    url = f"udpin:127.0.0.1:{rig.gcs_port}"
    r = gcs("params", "--connect", url, "--signing-key", key, "--timeout", 3, "set", "VEH_KF", 26.5)
    assert r.returncode == 0, r.stdout + r.stderr
    r = gcs("params", "--connect", url, "--signing-key", key, "--timeout", 3, "get", "VEH_KF")
    assert r.returncode == 0 and "26.5" in r.stdout, r.stdout + r.stderr
    # another key: octo-gcs does not even accept the vehicle's heartbeat, nothing is written
    # (unsigned writes: test_fw_mavlink.py)
    r = gcs("params", "--connect", url, "--signing-key", other, "--timeout", 1, "set", "VEH_KF", 30)
    assert r.returncode != 0, r.stdout
    r = gcs("params", "--connect", url, "--signing-key", key, "--timeout", 3, "get", "VEH_KF")
    assert r.returncode == 0 and "26.5" in r.stdout and "30" not in r.stdout, r.stdout + r.stderr

    # wrongly signed COMMAND_LONGs: no ACK, counted in SYS_STATUS.errors_count4
    from pymavlink import mavutil
    rig.m = mavutil.mavlink_connection(url, source_system=255)
    rig.m.setup_signing(read_signing_key(key), sign_outgoing=True)
    assert rig.m.wait_heartbeat(timeout=5) is not None
    st0 = rig.recv({"SYS_STATUS"}, timeout=3)
    wrong = mavutil.mavlink_connection(f"udpout:127.0.0.1:{rig.mav_port}", source_system=253)
    wrong.setup_signing(read_signing_key(other), sign_outgoing=True)
    for _ in range(5):
        wrong.mav.command_long_send(1, 1, mavlink.MAV_CMD_PREFLIGHT_STORAGE, 0, 1, 0, 0, 0, 0, 0, 0)
    time.sleep(0.2)
    assert rig.recv({"COMMAND_ACK"}, timeout=0.5) is None
    st = None
    deadline = time.monotonic() + 4
    while time.monotonic() < deadline:
        st = rig.recv({"SYS_STATUS"}, timeout=2)
        if st is not None and st.errors_count4 >= st0.errors_count4 + 5:
            break
    assert st is not None and st.errors_count4 >= st0.errors_count4 + 5
    assert not rig.params.exists()          # the storage command never ran
    # the same command correctly signed is accepted
    r_, _ = rig.cmd(mavlink.MAV_CMD_PREFLIGHT_STORAGE, 1)
    assert r_ == mavlink.MAV_RESULT_ACCEPTED and rig.params.exists()
    wrong.close()


def test_model_and_mixer_parameters_locked_while_an_experiment_runs(launch, port, tmp_path):
    """Every VEH_*, MIX_*, MOT_* and ID_* write during an experiment is refused with the
    current value echoed and a reason; so is a parameter load; other groups stay writable;
    after the experiment the same writes go through."""
    import struct
    from ident_helpers import MAV_CMD_USER_1, IdentFlight
    # paced like X-Plane, not lockstep: the experiment then lasts 300 s of wall time, however
    # slowly a loaded machine answers the ~30 writes below (in lockstep it lasts ~1 s of wall)
    fl = IdentFlight(launch, port, tmp_path, seed=6, duration=3000, params={"ID_EXC_TIME": 300},
                     lockstep=False)
    fl.takeoff()
    rig = fl.rig
    _, table = rig.param_list()
    values = {m.param_id: m.param_value for m in table.values()}
    # every model and mixer parameter, and a sample of the identification group (each write
    # costs a round trip while the lockstep experiment runs on)
    locked = [n for n in values if n.split("_")[0] in ("VEH", "MIX", "MOT")]
    locked += ["ID_EXC_AMP", "ID_MOT_TAU", "ID_KF_EST"]
    assert {"VEH_KF", "VEH_KTAU", "VEH_IXX", "VEH_MASS", "MIX_MODE", "MOT_THR_MAX"} <= set(locked)
    r, texts = rig.cmd(MAV_CMD_USER_1, 1)
    assert r == mavlink.MAV_RESULT_IN_PROGRESS, texts
    t0 = time.monotonic()
    r, texts = rig.cmd(mavlink.MAV_CMD_PREFLIGHT_STORAGE, 0)          # load: would overwrite them
    assert r == mavlink.MAV_RESULT_TEMPORARILY_REJECTED, texts
    for name in locked:
        v = values[name]
        new = min(v * 1.01 + 0.001, 0.99) if name.startswith(("MOT_", "MIX_")) else v * 1.01 + 0.001
        msg, texts = rig.param_set(name, new)
        assert msg is not None, name
        if any(name in t and "read-only" in t for t in texts):
            # an identification result: written by the experiment itself, never by us
            assert struct.pack("<f", msg.param_value) != struct.pack("<f", new), name
            continue
        assert struct.pack("<f", msg.param_value) == struct.pack("<f", v), (name, v, msg.param_value)
        assert any(name in t and "locked" in t for t in texts), (name, texts)
    msg, _ = rig.param_set("NAV_LAND_VEL", 0.8)                      # not a model parameter
    assert msg is not None and abs(msg.param_value - 0.8) < 1e-6
    hb = rig.recv({"HEARTBEAT"}, timeout=2)
    assert hb.custom_mode == 4, "the experiment ended before the checks did"   # still EXPERIMENT
    print(f"{len(locked)} locked writes refused in {time.monotonic() - t0:.2f} s")
    # stopped: the model is writable again
    r, _ = rig.cmd(MAV_CMD_USER_1, 0)
    # the first ACK may be the stopped experiment's own final one (FAILED), then ours
    assert r in (mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_FAILED)
    fl.wait_text(lambda t: t == "Mode HOLD", 5)
    msg, _ = rig.param_set("VEH_KF", 27.0)
    assert msg is not None and msg.param_value == 27.0
