"""The mission report under the IMU source, on synthetic results (no vehicle needed): k_tau and
I_z are reported as not identifiable from the gyro alone (no value, not a failure), the ratio
k_tau / I_z is judged against the truth within max(3 sd, 2 %), each rotor's effectiveness is
not identified, and the checks fail when something accepted is wrong or something the data
cannot determine was applied. The results.csv row carries the ratio and what was not
identifiable."""

import math
import random
import types

import pytest

from octo_gcs import campaign, campaign_spec, checks
from octo_gcs.mission import report
from octo_gcs.vehiclefile import load

TRUTH = {"kf": 28.0269, "ktau": 0.3869, "ixx": 0.0628, "iyy": 0.0762, "izz": 0.1014}
RATIO = TRUTH["ktau"] / TRUTH["izz"]
NOMINAL = {"VEH_KF": 20.0, "VEH_KTAU": 0.3, "VEH_IXX": 0.05, "VEH_IYY": 0.05, "VEH_IZZ": 0.05}
ARGS = types.SimpleNamespace(vehicle=None, seed=1, realtime=False, xplane_version=12, sensors=["imu"])
# OCTO_ID_PARAM, OCTO_ID_REASON, OCTO_ID_SOURCE codes (the dialect's)
KF, KTAU, IXX, IYY, IZZ, MOT_TAU, KTIZ = 1, 2, 3, 4, 5, 6, 12
OK, UNCERTAIN, NOT_IDENTIFIABLE = 0, 3, 18
IMU = 2


def rec(i, exp, param, value, sd, accepted, reason=OK):
    return {"run_id": 1, "index": i, "count": 9, "run_done": int(i == 8), "experiment": exp, "param": param,
            "rotor": 0, "value": value, "sd": sd, "accepted": int(accepted), "reason": reason, "source": IMU}


def imu_run(rng, ratio=None, ratio_sd=None, ratio_ok=True):
    """(after, records) of an IMU identification near the truth: k_f, I_x, I_y with their sds,
    k_tau and I_z not identifiable, the ratio (default: the truth within its sd)."""
    kf, ixx, iyy = (TRUTH[k] * (1 + rng.uniform(-0.002, 0.002)) for k in ("kf", "ixx", "iyy"))
    ratio = RATIO * (1 + rng.uniform(-0.004, 0.004)) if ratio is None else ratio
    ratio_sd = 0.005 * RATIO if ratio_sd is None else ratio_sd
    after = dict(NOMINAL, ID_KF_EST=kf, ID_KF_SD=0.004 * kf, VEH_KF=kf, ID_IXX_EST=ixx, ID_IXX_SD=0.004 * ixx,
                 VEH_IXX=ixx, ID_IYY_EST=iyy, ID_IYY_SD=0.004 * iyy, VEH_IYY=iyy, ID_KTIZ=ratio,
                 ID_KTIZ_SD=ratio_sd, ID_SRC_USED=2.0, ID_IZZ_PRI_SD=0.0, ID_RESULT=7.0, ID_RSD_MAX=0.02,
                 ID_TAU_CHECK=0.03, ID_TAU_SD=1e-4, ID_DELAY_FR=0.0, MOT_CURVE=0.0, ID_CRV_SD=0.005,
                 VEH_MASS=2.132, VEH_ARM_L=0.35, VEH_GRAV=9.796, ID_VAL_NE_PRE=0.28, ID_VAL_FIT_PRE=-200.0,
                 ID_VAL_NE_POST=0.018, ID_VAL_FIT_POST=70.0, **{f"MOT_SCALE{j}": 1.0 for j in range(1, 9)})
    nan = float("nan")
    recs = [rec(0, 1, KF, kf, 0.004 * kf, True), rec(1, 1, KTAU, nan, nan, False, NOT_IDENTIFIABLE),
            rec(2, 1, MOT_TAU, 0.03, 1e-4, True), rec(3, 3, IXX, ixx, 0.004 * ixx, True),
            rec(4, 4, IYY, iyy, 0.004 * iyy, True),
            rec(5, 5, KTIZ, ratio, ratio_sd, ratio_ok, OK if ratio_ok else UNCERTAIN),
            rec(6, 5, KTAU, nan, nan, False, NOT_IDENTIFIABLE), rec(7, 5, IZZ, nan, nan, False, NOT_IDENTIFIABLE)]
    return after, recs


def build(tmp_path, after, recs, nominal=NOMINAL):
    return report.build_report(tmp_path, load(None), ARGS, nominal, after, [6], logs=None, results=recs)


def failed(rep):
    return [c["check"] for c in rep["checks"] if not c["ok"] and not c["warning_only"]]


def test_imu_report_states_the_ratio_and_what_is_not_identifiable(tmp_path):
    rng = random.Random()
    after, recs = imu_run(rng)
    rep = build(tmp_path, after, recs)
    assert rep["pass"], failed(rep)
    assert rep["estimator"]["source"] == "imu"
    for key in ("ktau", "izz"):
        row = rep["parameters"][key]
        assert row["identifiable"] is False and row["estimate"] is None and row["reason"] == "not_identifiable"
        assert row["accepted"] is False and row["source"] == "imu"
    for key in ("kf", "ixx", "iyy"):
        assert rep["parameters"][key]["accepted"] and "identifiable" not in rep["parameters"][key]
    x = rep["ktau_over_izz"]
    assert x["estimate"] == pytest.approx(after["ID_KTIZ"]) and x["truth"] == pytest.approx(RATIO)
    assert x["accepted"] and x["error_pct"] == pytest.approx(100 * (after["ID_KTIZ"] / RATIO - 1), abs=1e-4)
    names = [c["check"] for c in rep["checks"]]
    assert "k_tau estimated" not in names and "I_z vs truth" not in names and "k_tau/I_z vs truth" in names
    assert "k_tau not identifiable from the gyro alone" in names and "I_z not identifiable from the gyro alone" in names
    text = report.table_text(rep)
    assert text.count("not identifiable from the gyro alone") == 3 and "k_tau/I_z [1/s^2]" in text
    assert "k_tau and I_z: not identifiable from the gyro alone (source imu, no ESC torque): their ratio" in text
    assert text.count("not identified (source imu)") == 8
    assert "measured collective force m g a_z vs the modelled thrusts' sum, firmware" in text
    md = report.markdown(rep)
    assert "| k_tau/I_z [1/s^2] |" in md and "k_tau/I_z 2.0 % or 3 sd" in md
    # results.csv: the ratio's columns and what was not identifiable
    spec = campaign_spec.validate({"missions": 1, "sensors": "imu"})
    res = {"index": 0, "seed": 1, "status": "pass", "reason": "", "wall_s": 1.0, "report": report.public(rep),
           "rejections": campaign._rejections(rep)}
    row = campaign.result_row(res, campaign_spec.draws(spec, 0))
    assert set(row) == set(campaign.csv_columns(spec))
    assert float(row["ktiz_estimate"]) == pytest.approx(after["ID_KTIZ"]) and row["ktiz_accepted"] == 1
    assert row["not_identifiable"] == "ktau izz" and row["ktau_estimate"] == "" and row["rejection_reasons"] == ""


@pytest.mark.parametrize("off_pct, sd_pct, ok", [(1.5, 0.2, True), (2.5, 0.2, False), (2.5, 1.0, True),
                                                  (-3.5, 1.0, False)])
def test_ratio_is_judged_within_3_sd_or_2_percent(tmp_path, off_pct, sd_pct, ok):
    after, recs = imu_run(random.Random(), ratio=RATIO * (1 + off_pct / 100), ratio_sd=RATIO * sd_pct / 100)
    rep = build(tmp_path, after, recs)
    assert rep["pass"] is ok and (failed(rep) == [] if ok else failed(rep) == ["k_tau/I_z vs truth"]), failed(rep)


def test_a_rejected_or_missing_ratio_fails(tmp_path):
    after, recs = imu_run(random.Random(), ratio_ok=False)
    rep = build(tmp_path, after, recs)
    assert "k_tau/I_z accepted" in failed(rep) and "no: uncertain" in report.table_text(rep)
    after, recs = imu_run(random.Random())
    after["ID_KTIZ"], after["ID_KTIZ_SD"] = 0.0, 0.0
    recs = [r for r in recs if r["param"] != KTIZ]
    assert "k_tau/I_z estimated" in failed(build(tmp_path, after, recs))


def test_a_value_applied_that_the_gyro_cannot_determine_fails(tmp_path):
    after, recs = imu_run(random.Random())
    after["VEH_IZZ"] = 0.09
    rep = build(tmp_path, after, recs)
    assert failed(rep) == ["I_z not identifiable from the gyro alone"], failed(rep)
    assert "VEH_IZZ changed" in [c for c in rep["checks"] if not c["ok"]][0]["detail"]


def test_accepted_but_wrong_inertia_still_fails(tmp_path):
    """The roll and pitch inertias rest on the rotor model: one accepted far from the truth is a
    failure whatever the source."""
    after, recs = imu_run(random.Random())
    after["ID_IXX_EST"] = after["VEH_IXX"] = 0.7 * TRUTH["ixx"]
    rep = build(tmp_path, after, recs)
    assert failed(rep) == ["I_x vs truth"]


def test_k_tau_from_an_izz_prior_is_judged_as_an_estimate(tmp_path):
    """With ID_IZZ_PRI_SD > 0 the firmware gives k_tau = VEH_IZZ x the ratio with the prior's sd:
    an estimate like any other, against the truth; I_z stays not identifiable."""
    after, recs = imu_run(random.Random())
    kt = after["ID_KTIZ"] * 0.1
    after.update(ID_IZZ_PRI_SD=0.01, VEH_IZZ=0.1, ID_KTAU_EST=kt, ID_KTAU_SD=0.011 * kt, VEH_KTAU=kt)
    recs = [r for r in recs if not (r["param"] == KTAU and r["experiment"] == 5)]
    recs.append(rec(8, 5, KTAU, kt, 0.011 * kt, True))
    rep = build(tmp_path, after, recs, dict(NOMINAL, VEH_IZZ=0.1))
    row = rep["parameters"]["ktau"]
    assert row["estimate"] == pytest.approx(kt) and row["accepted"] and "identifiable" not in row
    assert rep["parameters"]["izz"]["identifiable"] is False
    assert rep["pass"], failed(rep)
    names = [c["check"] for c in rep["checks"]]
    assert "k_tau vs truth" in names and "k_tau not identifiable from the gyro alone" not in names
    assert "I_z: not identifiable from the gyro alone (source imu, no ESC torque): the ratio k_tau/I_z is " \
        "identified, k_tau from it with the prior on I_z" in report.table_text(rep)


def test_params_alone_say_what_the_source_cannot_determine():
    """Without result records (octo-gcs identify on a vehicle without them) ID_SRC_USED and
    ID_IZZ_PRI_SD say which quantities have only their ratio."""
    after, _recs = imu_run(random.Random())
    assert checks.unidentifiable(after) == {"ktau", "izz"}
    assert checks.unidentifiable(dict(after, ID_IZZ_PRI_SD=0.05)) == {"izz"}
    assert checks.unidentifiable(dict(after, ID_SRC_USED=1.0)) == set()
    lines = []
    status = checks.report_checks(after, [6], TRUTH, 0.3, 2.0, out=lines.append)
    assert status == 0, lines
    assert any("k_tau  not identifiable" in ln for ln in lines) and any("k_tau/I_z vs truth" in ln for ln in lines)
    bad = dict(after, ID_KTIZ=RATIO * 1.05)
    assert checks.report_checks(bad, [6], TRUTH, 0.3, 2.0, out=lines.append) == 1
    assert math.isclose(checks.ratio_row(after, None, RATIO)["truth"], RATIO)
