"""convergence.png shows each quantity's identification result, the estimate that is applied,
with its sd (from report.json's parameters, or from the firmware log's OCTO_ID_RESULT records
when there is no report), and labels the live recursive estimates beside it as auxiliary.
Checked on the figure's own data (its lines and their labels), on synthetic logs."""

import sys

import numpy as np
import pytest

from conftest import BUILD

sys.path.insert(0, str(BUILD / "gen" / "python"))

from octo_gcs import plots  # noqa: E402
from octo_gcs.logs import Logs  # noqa: E402
from octo_gcs.mission import report  # noqa: E402
from octo_gcs.quantities import QUANTITIES  # noqa: E402
from octo_gcs.vehiclefile import load  # noqa: E402
from test_gcs_report import ARGS, NOMINAL, params_after, write_synthetic_logs  # noqa: E402


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    write_synthetic_logs(d)
    return Logs([d / "truth.lcm", d / "fw.lcm"])


def drawn(logs, rep, monkeypatch, tmp_path):
    """{quantity key: [(label, y data) of each labelled line]} of the convergence figure."""
    figs = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figs.append(fig))
    plots.convergence(logs, rep, str(tmp_path / "c.png"), plots._plt())
    (fig,) = figs
    out = {}
    for ax, q in zip(fig.axes, QUANTITIES):
        out[q.key] = [(ln.get_label(), np.asarray(ln.get_ydata(), float)) for ln in ax.get_lines()
                      if not ln.get_label().startswith("_")]
    plots._plt().close("all")
    return out


def result_line(lines):
    hits = [(lab, y) for lab, y in lines if lab.startswith("identification result")]
    assert len(hits) == 1, [lab for lab, _ in lines]
    return hits[0]


def test_the_applied_result_and_its_sd_beside_the_auxiliary_live_estimates(logs, monkeypatch, tmp_path):
    """Every quantity: one line at the report's estimate, labelled with its sd and whether it
    was applied; the live traces (lag-aware RLS, plain LS) labelled auxiliary. The applied k_f
    here (28.03) differs from where the live RLS ends (the truth, 28.0269): the figure shows the
    former as the result."""
    after = params_after(ID_RESULT=13.0)  # I_x (bit 2) not accepted
    rep = report.build_report(tmp_path, load(None), ARGS, NOMINAL, after, [6], logs=logs)
    lines = drawn(logs, rep, monkeypatch, tmp_path)
    for q in QUANTITIES:
        row = rep["parameters"][q.key]
        lab, y = result_line(lines[q.key])
        assert np.allclose(y, row["estimate"]), (q.key, y, row["estimate"])
        assert f"sd {row['sd']:.2g}" in lab
        assert ("; applied)" in lab) == row["accepted"] and (q.key != "ixx" or "not applied" in lab)
        others = [lab for lab, _ in lines[q.key] if lab not in ("truth",) and not lab.startswith("identification")]
        assert others and all(lab.startswith("auxiliary") for lab in others), others
    live_kf = [y for lab, y in lines["kf"] if lab.startswith("auxiliary: live lag-aware")][0]
    assert abs(live_kf[-1] - 28.03) > 0.002


def test_without_a_report_the_results_come_from_the_log_records(logs, monkeypatch, tmp_path):
    """`octo-gcs plot` has logs only: the results are the firmware's OCTO_ID_RESULT records."""
    from octo_gcs import id_results

    code = {id_results.param_name(c): c for c in range(1, 40)}
    recs = [{"run_id": 1, "index": i, "count": 2, "run_done": i == 1, "experiment": 1, "param": code[name],
             "rotor": 0, "value": v, "sd": sd, "accepted": 1, "reason": 0, "source": 0}
            for i, (name, v, sd) in enumerate((("kf", 27.95, 0.12), ("ktau", 0.3871, 0.002)))]

    class WithRecords:
        def __init__(self, base):
            self._base, self.id_results = base, recs

        def __getattr__(self, name):
            return getattr(self._base, name)

    lines = drawn(WithRecords(logs), {"truth": {}}, monkeypatch, tmp_path)
    lab, y = result_line(lines["kf"])
    assert np.allclose(y, 27.95) and "sd 0.12" in lab
    lab, y = result_line(lines["ktau"])
    assert np.allclose(y, 0.3871) and "sd 0.002" in lab
    assert not any(lab.startswith("identification") for lab, _ in lines["ixx"])
