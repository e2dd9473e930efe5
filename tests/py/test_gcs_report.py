"""Unit tests of octo-gcs's report builder, figures and identification checks, on
synthetic LCM logs whose truth is known exactly (no vehicle needed)."""

import json
import math
import os
import sys
import types

import numpy as np
import pytest

from conftest import BUILD

sys.path.insert(0, str(BUILD / "gen" / "python"))

from octo_gcs import analysis, checks, experiments, identify  # noqa: E402
from octo_gcs.base import GcsError  # noqa: E402
from octo_gcs.mission import report  # noqa: E402
from octo_gcs.logs import Logs, LogTail, find_logs  # noqa: E402
from octo_gcs.model import Params  # noqa: E402
from octo_gcs.vehiclefile import VehicleFileError, load, parse, truth_of  # noqa: E402

RATE = 90.0
TRUTH = {"kf": 28.0269, "ktau": 0.3869, "ixx": 0.0628, "iyy": 0.0762, "izz": 0.1014}
PHASES = [("validation", 10, 15), ("rotor coefficients", 15, 25), ("validation", 25, 30),
          ("Ixx", 30, 35), ("Iyy", 35, 40), ("Izz", 40, 45)]


def write_synthetic_logs(d, kf_nominal=20.0):
    """A truth log and a firmware log of a made-up sequence 6: phases as events,
    excitation, commanded/measured f_1, converging estimates, and body rates that
    the paper's model itself produced from the logged throttles (so the model fits)."""
    import lcm
    from octo import fw_event_t, fw_frame_t, truth_t

    rng = np.random.default_rng(1)
    n = int(50 * RATE)
    t = np.arange(n) / RATE
    p = Params()
    th = p.mass * p.g / (8 * p.kf)
    thr = np.full((n, 8), th)
    # torque excitation in the inertia phases: +/- on opposite rotors
    for name, a, b in PHASES[3:]:
        m = (t >= a) & (t < b)
        s = 0.004 * np.sign(np.sin(2 * math.pi * 1.5 * t[m]))
        if name == "Ixx":
            thr[m][:, [1, 2, 3]] += 0   # (views: assign below)
            thr[np.ix_(m, [1, 2, 3])] += s[:, None]
            thr[np.ix_(m, [5, 6, 7])] -= s[:, None]
        elif name == "Iyy":
            thr[np.ix_(m, [7, 0, 1])] += s[:, None]
            thr[np.ix_(m, [3, 4, 5])] -= s[:, None]
        else:
            thr[np.ix_(m, [0, 2, 4, 6])] += 4 * s[:, None]
            thr[np.ix_(m, [1, 3, 5, 7])] -= 4 * s[:, None]
    # truth: rates from the model itself (row k's command acts from t[k-1] to t[k])
    w = analysis.simulate_rates(t, [1, 0, 0, 0], [0, 0, 0], np.vstack([thr[1:], thr[-1:]]), thr[0], p)
    truth_log = lcm.EventLog(str(d / "truth.lcm"), "w", overwrite=True)
    for k in range(n):
        m = truth_t()
        m.utime, m.frame, m.t = int(round(t[k] * 1e6)), k, t[k]
        m.q_i2b = [1.0, 0.0, 0.0, 0.0]
        m.rate_b = list(w[k])
        m.throttle_cmd = list(thr[k])
        m.s = list(thr[k])
        m.thrust = list(p.kf * thr[k])
        m.mass, m.g, m.arm_length, m.kf, m.ktau = p.mass, p.g, p.arm_length, p.kf, p.ktau
        m.inertia = list(p.inertia)
        truth_log.write_event(m.utime, "OCTO_TRUTH", m.encode())
    truth_log.close()

    fw_log = lcm.EventLog(str(d / "fw.lcm"), "w", overwrite=True)
    events = [(a, f"ID {i + 1}/6: {name}") for i, (name, a, b) in enumerate(PHASES)] + [(45.0, "ID done")]
    ev_i = 0
    for k in range(n):
        while ev_i < len(events) and events[ev_i][0] <= t[k] + 1e-9:
            e = fw_event_t()
            e.utime, e.severity, e.text = int(round(events[ev_i][0] * 1e6)), 6, events[ev_i][1]
            fw_log.write_event(e.utime, "OCTO_FW_EVENT", e.encode())
            ev_i += 1
        f = fw_frame_t()
        f.utime, f.seq, f.t, f.dt, f.stepped, f.mode = int(round(t[k] * 1e6)), k + 1, t[k], 1 / RATE, True, 3
        kf_used = kf_nominal if t[k] < 25 else TRUTH["kf"]
        mu = 0.05 * math.sin(2 * math.pi * 0.8 * t[k]) if (10 <= t[k] < 15 or 25 <= t[k] < 30) else 0.0
        f.tau_dem = [0.0, 0.0, 0.0]
        f.tau_alloc = [0.0, 0.0, mu]      # the experiment's mu_1 rides on the yaw demand
        f_cmd = 2.61 + 8 * mu
        f.rotor_f = [f_cmd] + [2.61] * 7
        f.throttle = [f_cmd / kf_used] + list(thr[k, 1:])
        f.rotor_thrust = [TRUTH["kf"] * f_cmd / kf_used + rng.normal(0, 0.02)] + [2.61] * 7
        f.excitation = [rng.uniform(-0.05, 0.05) if 15 <= t[k] < 25 else 0.0] + [0.0] * 7
        est, sd = [0.0] * 8, [0.0] * 8
        for name, a, b in PHASES:
            if a <= t[k] < b and name != "validation":
                x = (t[k] - a + 0.1) / (b - a)
                keys = ((0, "kf"), (1, "ktau")) if name.startswith("rotor") else \
                    (({"Ixx": 4, "Iyy": 5, "Izz": 6}[name], name.lower()),)
                for slot, key in keys:
                    sd[slot] = TRUTH[key] * 0.01 / math.sqrt(x * 90)
                    est[slot] = TRUTH[key] * (1 + 0.05 * math.exp(-8 * x))
        f.est, f.est_sd = est, sd
        f.exp_id = 6 if 10 <= t[k] < 45 else 0
        f.q = [1.0, 0.0, 0.0, 0.0]
        f.rate_b = list(w[k])
        f.kf, f.ktau, f.inertia, f.mass = kf_used, 0.3869, [0.0628, 0.0762, 0.1014], p.mass
        fw_log.write_event(f.utime, "OCTO_FW_FRAME", f.encode())
    fw_log.close()
    return d / "truth.lcm", d / "fw.lcm"


def params_after(**over):
    p = {"ID_KF_EST": 28.03, "ID_KF_SD": 0.01, "ID_KF_PLAIN": 25.55, "ID_KTAU_EST": 0.38695,
         "ID_KTAU_SD": 0.0002, "ID_KTAU_PLAIN": 0.353, "ID_IXX_EST": 0.0630, "ID_IXX_SD": 0.0002,
         "ID_IYY_EST": 0.0760, "ID_IYY_SD": 0.0002, "ID_IZZ_EST": 0.1016, "ID_IZZ_SD": 0.0004,
         "ID_VAL_NE_PRE": 0.3, "ID_VAL_FIT_PRE": 20.0, "ID_VAL_NE_POST": 0.02, "ID_VAL_FIT_POST": 95.0,
         "ID_RESULT": 15.0, "ID_RSD_MAX": 0.01, "ID_MOT_TAU": 0.0, "VEH_MASS": 2.132, "VEH_ARM_L": 0.35,
         "VEH_GRAV": 9.796}
    for k, q in (("KF", "VEH_KF"), ("KTAU", "VEH_KTAU"), ("IXX", "VEH_IXX"), ("IYY", "VEH_IYY"),
                 ("IZZ", "VEH_IZZ")):
        p[q] = p[f"ID_{k}_EST"]
    p.update(over)
    return p


NOMINAL = {"VEH_KF": 20.0, "VEH_KTAU": 0.3, "VEH_IXX": 0.05, "VEH_IYY": 0.05, "VEH_IZZ": 0.05}
ARGS = types.SimpleNamespace(vehicle=None, seed=1, realtime=False, xplane_version=12)


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    write_synthetic_logs(d)
    return d


def test_logs_are_read_by_channel_and_phases_found(synthetic):
    logs = Logs(find_logs([str(synthetic)]))
    assert len(logs.truth) == len(logs.fw) == 4500
    assert logs.fw.rotor_f.shape == (4500, 8)
    kinds = analysis.phases(logs)
    assert kinds["validation"] == [(10.0, 15.0), (25.0, 30.0)]
    assert kinds["rotor"] == [(15.0, 25.0)]
    assert kinds["ixx"] == [(30.0, 35.0)] and kinds["izz"] == [(40.0, 45.0)]
    tail = LogTail(str(synthetic / "fw.lcm"))
    assert tail.time() == pytest.approx(4499 / RATE)
    tail.close()


@pytest.mark.parametrize("name,kind", [
    ("validation", "validation"), ("validation (nominal)", "validation"), ("rotor coefficients", "rotor"),
    ("k_f, k_tau", "rotor"), ("Ix", "ixx"), ("Ixx", "ixx"), ("I_y", "iyy"), ("inertia Iz", "izz"),
    ("yaw inertia", "izz"), ("roll", "ixx"), ("settle", None)])
def test_phase_names_are_classified(name, kind):
    assert analysis.classify(name) == kind


def test_report_table_json_and_markdown(synthetic, tmp_path):
    logs = Logs([synthetic / "truth.lcm", synthetic / "fw.lcm"])
    after = params_after()
    rep = report.build_report(tmp_path, load(None), ARGS, NOMINAL, after, [6], wall_flight_s=1.5, logs=logs)
    kf = rep["parameters"]["kf"]
    assert kf["paper"] == 28.0269 and kf["truth"] == pytest.approx(28.0269) and kf["nominal"] == 20.0
    assert kf["estimate"] == pytest.approx(28.03) and kf["sd"] == pytest.approx(0.01)
    assert kf["error_pct"] == pytest.approx(100 * (28.03 - 28.0269) / 28.0269, abs=1e-4)
    assert kf["plain_error_pct"] == pytest.approx(100 * (25.55 - 28.0269) / 28.0269, abs=1e-4)
    assert rep["parameters"]["ixx"]["plain"] is None and rep["parameters"]["izz"]["accepted"]
    assert rep["pass"], [c for c in rep["checks"] if not c["ok"]]
    # validation from the log: (a) nominal k_f 20 for 28 -> poor; (b) after: good
    (b, a) = rep["validation"]["from_log"]
    assert b["window"].startswith("before") and a["window"].startswith("after")
    assert b["ne"] > 0.25 and a["ne"] < 0.02 and a["fit_pct"] > 90 > b["fit_pct"]
    # Fig. 7: rates made by the model itself are fitted (estimates within 0.3 %)
    fits = {m["experiment"]: m["fit_pct"] for m in rep["model_fit"]}
    assert set(fits) == {"ixx", "iyy", "izz"}
    assert fits["ixx"]["wx"] > 95 and fits["iyy"]["wy"] > 95 and fits["izz"]["wz"] > 95
    # JSON: no private keys, no NaN
    text = report.dumps(rep)
    back = json.loads(text)
    assert "_logs" not in back and back["parameters"]["kf"]["estimate"] == pytest.approx(28.03)
    # the printed table and the markdown carry Table 1 beside truth and both estimates
    table = report.table_text(rep)
    assert "28.0269" in table and "25.55" in table and "+0.011 %" in table and "-8.838 %" in table
    md = report.markdown(rep, ["fig6_validation.png"])
    table1 = md.split("## Validation")[0]
    assert table1.count("\n| ") == 6 and "lag-aware" in md and "![fig6_validation.png]" in md
    assert "## Motor model found in flight" in md and "| rotor 8 effectiveness |" in md
    assert "Overall: **PASS**" in md


def test_report_fails_on_a_wrong_or_missing_estimate(synthetic, tmp_path):
    logs = Logs([synthetic / "truth.lcm", synthetic / "fw.lcm"])
    bad = params_after(ID_IYY_EST=0.0790, VEH_IYY=0.0790)            # +3.7 %: beyond 2 %
    rep = report.build_report(tmp_path, load(None), ARGS, NOMINAL, bad, [6], logs=logs)
    failed = [c["check"] for c in rep["checks"] if not c["ok"]]
    assert not rep["pass"] and failed == ["I_y vs truth"]
    missing = params_after(ID_IZZ_EST=0.0, ID_RESULT=7.0)
    rep = report.build_report(tmp_path, load(None), ARGS, NOMINAL, missing, [6], logs=logs)
    failed = [c["check"] for c in rep["checks"] if not c["ok"]]
    assert "I_z estimated" in failed and "I_z vs truth" in failed and not rep["pass"]
    assert rep["parameters"]["izz"]["estimate"] is None
    json.loads(report.dumps(rep))


def test_figures_are_written_atomically(synthetic, tmp_path):
    logs = Logs([synthetic / "truth.lcm", synthetic / "fw.lcm"])
    rep = report.build_report(tmp_path, load(None), ARGS, NOMINAL, params_after(), [6], logs=logs)
    names = report.write_outputs(tmp_path, rep)
    assert names == ["fig5_excitation.png", "fig6_validation.png", "fig7_rates.png", "convergence.png"]
    for n in names:
        data = (tmp_path / n).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10000
    assert sorted(os.listdir(tmp_path)) == sorted(names + ["report.md"]), "temporary files left"


def test_plot_command_from_logs(synthetic, tmp_path, capsys):
    from octo_gcs.cli import main
    assert main(["plot", str(synthetic / "truth.lcm"), str(synthetic / "fw.lcm"), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "4 figures" in out and "fit" in out
    assert main(["plot", str(tmp_path / "nope.lcm")]) == 1
    assert "no such log" in capsys.readouterr().err
    # a real X-Plane gives no truth log: the figures come from the firmware log alone
    only_fw = tmp_path / "fw-only"
    assert main(["plot", str(synthetic / "fw.lcm"), "--out", str(only_fw)]) == 0
    assert "from the firmware log" in capsys.readouterr().out
    assert len(list(only_fw.glob("*.png"))) == 4
    (tmp_path / "junk.lcm").write_bytes(b"not a log at all, not at all")
    assert main(["plot", str(tmp_path / "junk.lcm")]) == 1
    assert "not an LCM event log" in capsys.readouterr().err


def test_progress_one_updating_line_on_a_tty_plain_lines_otherwise():
    import io
    from octo_gcs.progress import Progress
    tty = io.StringIO()
    p = Progress(stream=tty, tty=True)
    p.update("ID 1/6 validation  t=  1.00 s", key=1)
    p.update("ID 1/6 validation  t=  2.00 s", key=1)
    p.say("  ID validation before: NE 0.2866")
    assert tty.getvalue().count("\r") >= 3 and tty.getvalue().count("\n") == 1
    plain = io.StringIO()
    p = Progress(stream=plain, tty=False, every=60)
    p.update("ID 1/6 validation", key=1)
    p.update("ID 1/6 validation again", key=1)      # same phase, too soon: no line
    p.update("ID 2/6 rotor coefficients", key=2)
    assert plain.getvalue() == "ID 1/6 validation\nID 2/6 rotor coefficients\n" and "\r" not in plain.getvalue()


# ---------------------------------------------------------------- identification checks
def test_live_status_texts_name_the_phases_not_the_results():
    live = identify.Live()
    for text in ["ID 1/6: validation", "ID 2/6: rotor coefficients", "ID kf 28.03 +/- 0.01 N accepted",
                 "ID Ixx 0.06 +/- 0.01 kg m^2 rejected: std too large", "Mode HOLD", "ID done"]:
        live.on_text(text, 6)
    assert (live.phase_k, live.phase_n, live.phase) == (2, 6, "rotor coefficients")
    assert len(live.results) == 0 and live.done == "done" and live.failure is None   # results come as data
    assert len(live.texts) == 5
    live = identify.Live()
    live.on_text("ID rotor coefficients failed: ID_ROT_TO 2.0 s", 3)   # severity ERROR: the vehicle's failure
    live.on_text("ID aborted: attitude limit", 3)
    assert live.done == "aborted: attitude limit"
    assert live.failure == "ID rotor coefficients failed: ID_ROT_TO 2.0 s"
    assert experiments.phase_of("ID 3/6: inertia Ixx") == (3, 6, "inertia Ixx")
    assert experiments.phase_of("ID kf 28.03 +/- 0.01 N accepted") is None


def test_plausibility_and_truth_checks():
    ok = checks.plausibility(params_after(), [6])
    assert all(c.ok for c in ok), [c.line() for c in ok if not c.ok]
    bad = checks.plausibility(params_after(ID_KF_SD=1.0, ID_RESULT=14.0, ID_VAL_NE_POST=0.5), [6])
    failed = {c.name for c in bad if not c.ok}
    assert failed == {"k_f relative std", "k_f accepted", "k_tau accepted",
                      "validation error after identification: NE halved or < 0.05"}
    assert {c.name for c in checks.plausibility(params_after(ID_KF_EST=float("nan")), [1]) if not c.ok} \
        == {"k_f estimated"}
    tr = checks.against_truth(params_after(), [1, 3], TRUTH, 0.3, 2.0)
    assert [c.name for c in tr] == ["k_f vs truth", "k_tau vs truth", "I_x vs truth"]
    assert all(c.ok for c in tr)
    # an inertia is judged against max(tolerance, 4 of its reported sds): +2.02 % with an sd of
    # 0.56 % (3.6 sd) passes, +2.5 % (4.5 sd) and +2.02 % with an sd of 0.3 % do not
    iy = {"ID_IYY_EST": 0.0762 * 1.0202, "ID_IYY_SD": 0.0762 * 0.0056}
    by = {c.name: c for c in checks.against_truth(params_after(**iy), [4], TRUTH, 0.3, 2.0)}
    assert by["I_y vs truth"].ok and "4 sd" in by["I_y vs truth"].detail
    for est, sd in ((1.025, 0.0056), (1.0202, 0.003)):
        bad = checks.against_truth(params_after(ID_IYY_EST=0.0762 * est, ID_IYY_SD=0.0762 * sd), [4], TRUTH, 0.3, 2.0)
        assert not {c.name: c for c in bad}["I_y vs truth"].ok
    assert experiments.parse_experiments("1,3 4") == [1, 3, 4]
    with pytest.raises(GcsError):
        experiments.parse_experiments("7")


def test_vehicle_files(tmp_path):
    assert truth_of(load(None)) == pytest.approx(TRUTH)
    v = parse('{"kf": 30, "inertia": [0.1, 0.2, 0.3]}')
    assert v["kf"] == 30 and v["ktau"] == 0.3869 and v["inertia"] == [0.1, 0.2, 0.3]
    for text, key in [('{"kf": -1}', "kf"), ('{"inertia": [1, 2]}', "inertia"), ('{"kf": NaN}', "kf"),
                      ('{"wings": 2}', "wings"), ("[1]", "object"), ("{", "JSON")]:
        with pytest.raises(VehicleFileError, match=key):
            parse(text)
    with pytest.raises(VehicleFileError, match="cannot read"):
        load(tmp_path / "missing.json")
