"""octo-gcs campaign's spec: validation errors that name the key, reproducible draws, the mission
inputs made from them (vehicle file, faults, parameters), the faults as the plants' flags."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from octo_gcs import campaign, campaign_spec as cs
from octo_gcs.base import GcsError
from octo_gcs.mission.options import MissionOptions, fault_flags

REPO = Path(__file__).resolve().parents[2]
DEFAULT = REPO / "host_tools" / "campaigns" / "default.json"


def spec(**kw):
    s = {"missions": 5, "seed": 7, "vehicle": {"kf": {"uniform": [20, 30]}}}
    s.update(kw)
    return s


@pytest.mark.parametrize("bad, names", [
    ({"missions": 3, "vehicles": {}}, "'vehicles'"),
    ({"missions": 3, "vehicle": {"kff": 3}}, "'kff'"),
    ({"missions": 3, "vehicle": {"kf": {"uniform": [30, 20]}}}, "vehicle.kf.uniform: empty range"),
    ({"missions": 3, "vehicle": {"kf": {"gauss": [30, 2]}}}, "vehicle.kf: unknown distribution 'gauss'"),
    ({"missions": 3, "vehicle": {"kf": {"uniform": [1]}}}, "vehicle.kf.uniform"),
    ({"missions": 3, "vehicle": {"kf": {"uniform": [-1, 3]}}}, "vehicle.kf"),
    ({"missions": 3, "vehicle": {"mass": {"loguniform": [0, 3]}}}, "vehicle.mass.loguniform: needs 0 < lo"),
    ({"missions": 3, "vehicle": {"inertia": [0.1, {"normal": [0.07, -1]}, 0.1]}}, "vehicle.inertia[1].normal"),
    ({"missions": 3, "vehicle": {"inertia": [0.1, 0.1]}}, "vehicle.inertia"),
    ({"missions": 3, "vehicle": {"rotor_scale": [1] * 7 + [{"choice": []}]}}, "vehicle.rotor_scale[7].choice"),
    ({"missions": 3, "vehicle": {"noise": {"gyros": 0.1}}}, "'gyros'"),
    ({"missions": 3, "vehicle": {"thrust_curve": {"uniform": [0, 1.5]}}}, "vehicle.thrust_curve"),
    ({"missions": 3, "faults": {"loss": 0.1}}, "faults: unknown key 'loss'"),
    ({"missions": 3, "faults": {"drop": {"uniform": [0, 2]}}}, "faults.drop"),
    ({"missions": 3, "faults": {"delay_frames": 1.5}}, "faults.delay_frames"),
    ({"missions": 3, "params": {"id_inr_time": 20}}, "'id_inr_time'"),
    ({"missions": 3, "params": {"VEH_MASS": 2}}, "params.VEH_MASS"),
    ({"missions": 0}, "missions"),
    ({"seed": 3}, "missions: missing"),
    ({"missions": 3, "plant": "tcp"}, "plant"),
    ({"missions": 3, "expect": {"kf_error": 0.3}}, "expect: unknown key 'kf_error'"),
    ({"missions": 3, "tolerance_pct": {"mass": 1}}, "tolerance_pct: unknown parameter 'mass'"),
    ({"missions": 3, "timeout": -1}, "timeout"),
    ({"missions": 3, "build": "double"}, 'build: "double" is not a build'),
    ({"missions": 3, "build": {"choice": ["float", "q15"]}}, 'build.choice[1]: "q15" is not a build'),
    ({"missions": 3, "build": {"uniform": [0, 1]}}, "build: a value or"),
    ({"missions": 3, "sensors": ["imu", "gps"]}, 'sensors: unknown sensor "gps"'),
    ({"missions": 3, "sensors": {"choice": ["imu", "baro"]}}, 'sensors.choice[1]: unknown sensor "baro"'),
    ({"missions": 3, "sensors": 4}, "sensors: must be a list of sensors"),
    ({"missions": 3, "sensors": [["imu"], ["gps"]]}, 'sensors[1]: unknown sensor "gps"'),
    ({"missions": 3, "sensors": [["imu", "thrust"], ["thrust", "imu"]]}, "sensors[1]: the same set as sensors[0]"),
    ({"missions": 3, "sensors": [["imu"], "thrust"]}, "sensors: must be a list of sensors"),
    ({"missions": 3, "vehicle": {"sensors": ["lidar"]}}, 'vehicle.sensors: unknown sensor "lidar"'),
    ({"missions": 3, "vehicle": {"noise": {"accels": 0.1}}}, "vehicle.noise: unknown key 'accels'"),
    ({"missions": 3, "vehicle": {"imu_bias": {"gyro_drift": 0.1}}}, "vehicle.imu_bias: unknown key 'gyro_drift'"),
    ({"missions": 3, "vehicle": {"imu_bias": {"gyro": -0.1}}}, "vehicle.imu_bias.gyro"),
    ({"missions": 3, "vehicle": {"vibration": {"harmonics": [1, 1, 1, 1, 1]}}}, "vehicle.vibration.harmonics"),
    ({"missions": 3, "vehicle": {"vibration": {"sample_hz": 50}}}, "vehicle.vibration.sample_hz"),
    ({"missions": 3, "vehicle": {"vibration": {"cutoff_hz": {"uniform": [20, 500]}}}},
     "vehicle.vibration.cutoff_hz: 500"),
    ({"missions": 3, "vehicle": {"imu_scale": 0.5}}, "vehicle.imu_scale: 0.5 is out of range"),
    ({"missions": 3, "vehicle": {"esc_pole_pairs": 6.5}}, "vehicle.esc_pole_pairs: must be a whole number"),
    ({"missions": 3, "vehicle": {"esc_pole_pairs": 0}}, "vehicle.esc_pole_pairs: 0 is out of range"),
    ({"missions": 3, "vehicle": {"rpm_max": 0}}, "vehicle.rpm_max"),
    ({"missions": 3, "vehicle": {"origin_shift_s": []}}, "vehicle.origin_shift_s"),
    ({"missions": 3, "vehicle": {"origin_shift_s": [-5]}}, "vehicle.origin_shift_s[0]"),
])
def test_spec_errors_name_the_key(bad, names):
    with pytest.raises(cs.SpecError) as e:
        cs.validate(bad)
    assert names in str(e.value)


def test_a_normal_draw_out_of_range_is_an_error_before_anything_runs():
    s = cs.validate({"missions": 200, "vehicle": {"mass": {"normal": [0.5, 1.0]}}})
    with pytest.raises(cs.SpecError, match=r"vehicle.mass.*narrow it"):
        cs.check_all_draws(s)


def test_cli_bad_spec_exit_status_2_names_the_key(tmp_path):
    p = tmp_path / "s.json"
    p.write_text(json.dumps({"missions": 2, "vehicle": {"arm": {"uniform": [0.2, 0.3]}}}))
    r = subprocess.run([sys.executable, "-m", "octo_gcs.cli", "campaign", str(p), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert "unknown key 'arm'" in r.stderr and str(p) in r.stderr
    assert not (tmp_path / "o").exists()   # refused before anything was written
    p.write_text("{not json")
    r = subprocess.run([sys.executable, "-m", "octo_gcs.cli", "campaign", str(p)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and "not valid JSON" in r.stderr


def test_same_spec_same_draws_and_missions_differ():
    s = cs.validate(json.loads(DEFAULT.read_text()))
    s2 = cs.validate(json.loads(DEFAULT.read_text()))
    a = [cs.draws(s, i) for i in range(s["missions"])]
    b = [cs.draws(s2, i) for i in reversed(range(s["missions"]))][::-1]   # order of drawing is irrelevant
    assert a == b
    kf = [d["vehicle.kf"] for d in a]
    assert len(set(kf)) == len(kf)
    lo, hi = s["vehicle"]["kf"]["uniform"]
    assert all(lo <= x <= hi for x in kf)
    # another seed: other draws
    s3 = cs.validate(dict(json.loads(DEFAULT.read_text()), seed=s["seed"] + 1))
    assert cs.draws(s3, 0)["vehicle.kf"] != a[0]["vehicle.kf"]
    # a key added to the spec does not move the draws of the others
    s4 = cs.validate(dict(json.loads(DEFAULT.read_text()), params={"ID_INR_TIME": {"uniform": [10, 20]}}))
    d4 = cs.draws(s4, 3)
    assert {k: v for k, v in d4.items() if not k.startswith("params.")} == a[3]


def test_distributions_have_their_shape():
    n = 4000
    s = cs.validate({"missions": n, "seed": 3, "vehicle": {
        "kf": {"normal": [28.0, 1.0]}, "ktau": {"loguniform": [0.1, 1.0]},
        "mass": {"uniform": [1.0, 4.0]}, "delay": {"choice": [0.0, 0.011, 0.022]}}})
    d = [cs.draws(s, i) for i in range(n)]
    kf = np.array([x["vehicle.kf"] for x in d])
    assert abs(kf.mean() - 28.0) < 0.1 and abs(kf.std() - 1.0) < 0.06
    lk = np.log10([x["vehicle.ktau"] for x in d])
    assert lk.min() >= -1 and lk.max() <= 0 and abs(np.mean(lk < -0.5) - 0.5) < 0.04
    m = np.array([x["vehicle.mass"] for x in d])
    assert m.min() >= 1 and m.max() <= 4 and abs(m.mean() - 2.5) < 0.06
    assert {x["vehicle.delay"] for x in d} == {0.0, 0.011, 0.022}


def test_mission_inputs_vehicle_faults_params():
    s = cs.validate({"missions": 3, "seed": 40, "vehicle": {
        "inertia": [0.05, {"uniform": [0.06, 0.08]}, 0.1], "noise": {"gyro": {"uniform": [0.005, 0.02]}},
        "rotor_scale": [1, 1, {"uniform": [0.85, 1.0]}, 1, 1, 1, 1, 1]},
        "faults": {"drop": 0.02, "delay_frames": {"choice": [1, 2]}, "duplicate": 0},
        "params": {"ID_INR_TIME": {"choice": [15, 25]}}})
    seed, d, veh, faults, params = cs.mission_inputs(s, 2)
    assert seed == 42
    assert veh["inertia"][0] == 0.05 and veh["inertia"][2] == 0.1 and 0.06 <= veh["inertia"][1] <= 0.08
    assert veh["rotor_scale"][2] == d["vehicle.rotor_scale[2]"] and veh["rotor_scale"][0] == 1.0
    assert set(veh["noise"]) == {"gyro"}
    assert faults == {"delay_frames": int(d["faults.delay_frames"]), "drop": 0.02}   # duplicate 0: off, left out
    assert fault_flags(faults) == ["--delay-frames", str(int(d["faults.delay_frames"])), "--drop", "0.02"]
    assert params == {"ID_INR_TIME": d["params.ID_INR_TIME"]} and params["ID_INR_TIME"] in (15.0, 25.0)
    # the vehicle file made from the draws is one octo-gcs (and octo-sim) accept
    from octo_gcs import vehiclefile
    vehiclefile.parse(json.dumps(veh))


def test_faults_reach_the_plants_flags_as_data(tmp_path):
    """A job's faults become the mission's options, and each plant's command line carries them
    as its flags (octo-sim for the UDP plant, octo-sil for the in-process one)."""
    from octo_gcs.mission import flying_sil, flying_udp

    job = {"index": 0, "seed": 7, "vehicle": {}, "faults": {"drop": 0.02, "delay_frames": 1},
           "params": {"ID_INR_TIME": 20.0}, "experiments": [6], "in_process": False}
    opts = campaign.mission_options(job, tmp_path)
    assert opts.plant == "udp" and opts.faults == {"drop": 0.02, "delay_frames": 1} and opts.plots is False
    assert MissionOptions.from_json(json.loads(json.dumps(opts.to_json()))) == opts
    flags = ["--delay-frames", "1", "--drop", "0.02"]
    sim = [str(a) for a in flying_udp.sim_argv(tmp_path, opts, (1, 2, 3, 4), tmp_path, 300.0)]
    assert sim[0].endswith("octo-sim") and sim[-4:] == flags and "--lockstep" in sim
    assert [str(a) for a in flying_udp.fw_argv(tmp_path, (1, 2, 3, 4), tmp_path)][0].endswith("octo-fw")
    sil = [str(a) for a in flying_sil.sil_argv(tmp_path, campaign.mission_options(dict(job, in_process=True),
                                                                                 tmp_path), tmp_path, 300.0)]
    assert sil[0].endswith("octo-sil") and sil[-4:] == flags
    with pytest.raises(GcsError, match="fault 'loss' unknown"):
        MissionOptions(faults={"loss": 0.1})
    with pytest.raises(GcsError, match="--realtime"):
        MissionOptions(plant="sil", realtime=True)
    assert "--fault drop=0.02" in campaign.replay_command(tmp_path, 0, 7, {"experiments": [6]}, {"drop": 0.02}, {})


def test_results_csv_drops_a_row_cut_short(tmp_path):
    s = cs.validate(spec())
    cols = campaign.csv_columns(s)
    path = tmp_path / "results.csv"
    rf = campaign.ResultsFile(path, cols)
    for i in range(2):
        res = {"index": i, "seed": 7 + i, "status": "crash", "reason": "x, \"quoted\"", "wall_s": 1.0, "host": "h"}
        rf.append(campaign.result_row(res, cs.draws(s, i)))
    rf.close()
    assert [r["index"] for r in campaign.read_results(path, cols)] == ["0", "1"]
    with open(path, "a") as f:
        f.write("2,9,pass,,1.0")   # a client killed while writing
    rows = campaign.read_results(path, cols)
    assert [r["index"] for r in rows] == ["0", "1"] and rows[1]["reason"] == "x, \"quoted\""
    assert path.read_text().endswith("\n") and path.read_text().count("\n") == 3
    with pytest.raises(campaign.CampaignError, match="columns"):
        campaign.read_results(path, cols[:-1])


BUILDS = REPO / "host_tools" / "campaigns" / "builds.json"


def test_sensor_keys_draws_and_the_vehicle_file_made_from_them():
    s = cs.validate({"missions": 6, "seed": 11, "sensors": {"choice": [["imu"], "thrust,torque"]},
                     "vehicle": {"noise": {"accel": 0.1, "rpm": {"uniform": [10, 30]}, "current": 0.05},
                                 "imu_bias": {"gyro": {"uniform": [0, 0.003]}, "accel_walk": 1e-4},
                                 "vibration": {"accel": 1.0, "harmonics": [1, {"uniform": [0, 0.5]}],
                                               "cutoff_hz": 40},
                                 "imu_scale": 0.01, "rpm_max": {"uniform": [8000, 10000]},
                                 "esc_pole_pairs": {"choice": [6, 7]}, "esc_kt": 0.0136,
                                 "esc_current_offset": {"normal": [0, 0.1]},
                                 "origin_shift_s": [30, {"uniform": [50, 60]}], "sensors": ["imu", "thrust"]}})
    cs.check_all_draws(s)
    from octo_gcs import vehiclefile
    seen = set()
    for i in range(s["missions"]):
        seed, d, veh, faults, params = cs.mission_inputs(s, i)
        w = cs.words(s, i)
        assert w["sensors"] in (["imu"], ["torque", "thrust"]) and d["sensors"] == ",".join(w["sensors"])
        seen.add(d["sensors"])
        assert veh["sensors"] == ["imu", "thrust"] and d["vehicle.sensors"] == "imu,thrust"
        assert veh["esc_pole_pairs"] in (6, 7) and isinstance(veh["esc_pole_pairs"], int)
        assert veh["vibration"]["harmonics"][0] == 1 and 0 <= veh["vibration"]["harmonics"][1] <= 0.5
        assert veh["origin_shift_s"][0] == 30 and 50 <= veh["origin_shift_s"][1] <= 60
        assert set(veh["noise"]) == {"accel", "rpm", "current"} and set(veh["imu_bias"]) == {"gyro", "accel_walk"}
        vehiclefile.parse(json.dumps(veh))
    assert len(seen) == 2
    # the vehicle's own list is what the plant serves when the spec says nothing else
    d = cs.draws(cs.validate({"missions": 1, "vehicle": {"sensors": ["thrust", "imu"]}}), 0)
    assert d["sensors"] == "imu,thrust" and cs.draws(cs.validate({"missions": 1}), 0)["sensors"] == "all"


def test_build_and_sensors_reach_the_missions_options_columns_and_replay(tmp_path):
    s = cs.validate({"missions": 8, "seed": 5, "build": {"choice": ["float", "fixed"]}, "sensors": "imu,rpm",
                     "vehicle": {"kf": {"uniform": [20, 30]}}})
    builds = [cs.draws(s, i)["build"] for i in range(s["missions"])]
    assert set(builds) == {"float", "fixed"}
    cols = campaign.csv_columns(s)
    assert cols[cols.index("host") + 1:cols.index("host") + 3] == ["build", "sensors"]
    jobs, _inputs = campaign._jobs(s, range(s["missions"]), True, None)
    for j, b in zip(jobs, builds):
        opts = campaign.mission_options(j, tmp_path)
        assert opts.build == b and opts.sensors == ["imu", "rpm"] and opts.plant == "sil"
    row = campaign.result_row({"index": 0, "seed": 5, "status": "pass", "reason": "", "wall_s": 1.0},
                              cs.draws(s, 0))
    assert row["build"] == builds[0] and row["sensors"] == "imu,rpm"
    cmd = campaign.replay_command(tmp_path, 3, 8, s, {}, {}, "fixed", ["imu", "rpm"])
    assert "--fixed" in cmd and "--sensors imu,rpm" in cmd
    assert "--fixed" not in campaign.replay_command(tmp_path, 3, 8, s, {}, {})
    assert "--in-process" in cmd and "--in-process" not in campaign.replay_command(
        tmp_path, 3, 8, dict(s, plant="udp"), {}, {})


def test_builds_spec_validates_and_flies_the_default_vehicles_on_both_builds():
    """builds.json is default.json with the build drawn: mission i flies default.json's vehicle i
    (each value has its own generator), on the float or the fixed build."""
    b = cs.validate(json.loads(BUILDS.read_text()))
    d = cs.validate(json.loads(DEFAULT.read_text()))
    cs.check_all_draws(b)
    assert b["missions"] >= d["missions"] and b["seed"] == d["seed"] and b["vehicle"] == d["vehicle"]
    builds = []
    for i in range(d["missions"]):
        db, dd = cs.draws(b, i), cs.draws(d, i)
        builds.append(db.pop("build"))
        assert dd.pop("build") == "float"
        assert db == dd, i
    n_fixed = builds.count("fixed")
    assert 0.25 * len(builds) <= n_fixed <= 0.75 * len(builds), builds
