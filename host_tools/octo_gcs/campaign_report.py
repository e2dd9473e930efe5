"""The campaign report: campaign.json, campaign.md and figures, from results.csv.

Per identified quantity, over the missions that ran: error statistics of the accepted estimates
(mean, sd, RMS, largest |error|, percent of truth), the normalised error z = (estimate - truth) / sd
against a standard normal (its mean and sd, a histogram and a QQ figure), the acceptance rate and
the firmware's rejection reasons counted. The headline is the number of SILENTLY WRONG estimates:
accepted although |estimate - truth| > max(3 sd, tolerance x truth). Then the worst missions with
the one command that replays each, and the throughput.
"""

import io
import json
import math
import statistics
from collections import Counter

from .atomicfile import atomic_write
from .campaign_spec import expect_key, flights
from .id_results import source_words
from .quantities import KEYS as QUANTITIES
from .quantities import LABELS

RATIO = "ktiz"  # k_tau / I_z: results.csv's ktiz_* (a source without ESC torque identifies it)
LABEL = dict(LABELS, **{RATIO: "k_tau/I_z"})
RAN = ("pass", "fail")
WORST = 10


def _f(x):
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _stats(xs):
    if not xs:
        return {"n": 0, "mean": None, "sd": None, "rms": None, "max_abs": None}
    return {
        "n": len(xs),
        "mean": statistics.fmean(xs),
        "sd": statistics.stdev(xs) if len(xs) > 1 else None,
        "rms": math.sqrt(statistics.fmean([x * x for x in xs])),
        "max_abs": max(abs(x) for x in xs),
    }


def _rejections(row):
    out = {}
    for part in (row.get("rejection_reasons") or "").split("; "):
        q, sep, why = part.partition(": ")
        if sep:
            out[q] = why
    return out


def keys_of(rows):
    """The quantities of the table: the five, and k_tau / I_z when a mission identified it."""
    has_ratio = any(_f(r.get(f"{RATIO}_estimate")) is not None for r in rows)
    return QUANTITIES + ((RATIO,) if has_ratio else ())


def analyse(spec, rows):
    ran = [r for r in rows if r["status"] in RAN]
    per = {}
    silently = []
    for q in keys_of(rows):
        tol = spec["tolerance_pct"][q]
        est_rows = [r for r in ran if _f(r[f"{q}_estimate"]) is not None and _f(r[f"{q}_truth"]) is not None]
        acc = [r for r in est_rows if r[f"{q}_accepted"] == "1"]
        errs = [_f(r[f"{q}_error_pct"]) for r in acc if _f(r[f"{q}_error_pct"]) is not None]
        z = []
        for r in est_rows:
            est, tru, sd = _f(r[f"{q}_estimate"]), _f(r[f"{q}_truth"]), _f(r[f"{q}_sd"])
            if sd and sd > 0:
                z.append((est - tru) / sd)
        reasons = Counter(
            _rejections(r).get(q, "no reason given") for r in est_rows if r[f"{q}_accepted"] != "1"
        )
        wrong = []
        for r in acc:
            est, tru, sd = _f(r[f"{q}_estimate"]), _f(r[f"{q}_truth"]), _f(r[f"{q}_sd"]) or 0.0
            if abs(est - tru) > max(3.0 * sd, tol / 100.0 * abs(tru)):
                wrong.append(int(r["index"]))
                silently.append(
                    {
                        "index": int(r["index"]),
                        "seed": int(r["seed"]),
                        "parameter": q,
                        "error_pct": _f(r[f"{q}_error_pct"]),
                        "sd_pct": 100.0 * sd / est if est else None,
                    }
                )
        zs = _stats(z)
        per[q] = {
            "label": LABEL[q],
            "tolerance_pct": tol,
            "estimated": len(est_rows),
            "accepted": len(acc),
            "acceptance_rate": len(acc) / len(est_rows) if est_rows else None,
            "error_pct_accepted": _stats(errs),
            "z": {"n": zs["n"], "mean": zs["mean"], "sd": zs["sd"]},
            "within_3sd_pct": 100.0 * sum(1 for x in z if abs(x) <= 3) / len(z) if z else None,
            "rejection_reasons": dict(reasons.most_common()),
            "silently_wrong": sorted(wrong),
            "_z": z,
            "_err": errs,
        }
    failures = Counter(f"{r['status']}: {r['reason']}"[:160] for r in rows if r["status"] not in RAN)
    return ran, per, silently, failures


def sources(rows):
    """{source: missions} of the missions that ran (the measurements their estimates rest on)."""
    return dict(Counter(r.get("source") or "not stated" for r in rows if r["status"] in RAN).most_common())


def counts(rows, column):
    """{value: missions} of a column of results.csv ("build", "sensors"), most common first."""
    return dict(Counter(r.get(column) or "-" for r in rows).most_common())


def groups(spec, rows):
    """The error table of each (build, sensors) the missions flew, when they flew more than one:
    [{"build", "sensors", "missions", "ran", "table": {quantity: statistics}}]."""
    keys = sorted({(r.get("build") or "float", r.get("sensors") or "all") for r in rows})
    if len(keys) < 2:
        return []
    out = []
    for b, sens in keys:
        sub = [r for r in rows if (r.get("build") or "float", r.get("sensors") or "all") == (b, sens)]
        ran, per, silently, _failures = analyse(spec, sub)
        out.append(
            {
                "build": b,
                "sensors": sens,
                "missions": len(sub),
                "ran": len(ran),
                "silently_wrong": len(silently),
                "sources": sources(sub),
                "_per": per,
                "parameters": {
                    q: {k: v for k, v in p.items() if not k.startswith("_")} for q, p in per.items()
                },
            }
        )
    return out


REFERENCE = "thrust"  # the source the others are compared with: each rotor's thrust and torque rows


def _value(row, q):
    """(estimate, sd, truth, accepted) of quantity q in a row of results.csv, or None. k_tau / I_z
    under the thrust rows is their k_tau over their I_z (sd from both, accepted when both are)."""
    est, sd, tru = (_f(row.get(f"{q}_{x}")) for x in ("estimate", "sd", "truth"))
    if est is not None:
        return est, sd, tru, row.get(f"{q}_accepted") == "1"
    if q != RATIO:
        return None
    k, i = _value(row, "ktau"), _value(row, "izz")
    if k is None or i is None or not k[0] or not i[0]:
        return None
    est = k[0] / i[0]
    rel = [x[1] / x[0] for x in (k, i) if x[1] is not None]
    sd = est * math.sqrt(sum(r * r for r in rel)) if len(rel) == 2 else None
    tru = k[2] / i[2] if k[2] and i[2] else None
    return est, sd, tru, k[3] and i[3]


def by_source(spec, rows):
    """The same vehicles flown with several sensor sets (results.csv's column "vehicle"): per
    quantity and source, the estimates against the truth and against the same vehicle's
    thrust-row estimate (the difference in percent of it and over the combined sd). None when
    the campaign did not fly sensor sets."""
    if not rows or "vehicle" not in rows[0]:
        return None
    ran = [r for r in rows if r["status"] in RAN]

    def src(r):
        return r.get("source") or "not stated"

    names = sorted({src(r) for r in ran}, key=lambda x: (x != REFERENCE, x))
    ref = {r["vehicle"]: r for r in ran if src(r) == REFERENCE}
    out = []
    for q in QUANTITIES + (RATIO,):
        tol = spec["tolerance_pct"][q]
        for name in names:
            sub = [r for r in ran if src(r) == name]
            vals = [(r, v) for r in sub for v in [_value(r, q)] if v is not None]
            n_ni = sum(1 for r in sub if q in (r.get("not_identifiable") or "").split())
            if not vals and not n_ni:
                continue
            acc = [(r, v) for r, v in vals if v[3] and v[2]]
            errs = [100.0 * (v[0] - v[2]) / v[2] for _r, v in acc]
            z = [(v[0] - v[2]) / v[1] for _r, v in vals if v[1] and v[2]]
            wrong = [
                r for r, v in acc if abs(v[0] - v[2]) > max(3.0 * (v[1] or 0.0), tol / 100.0 * abs(v[2]))
            ]
            pairs = []
            if name != REFERENCE:
                for r, v in acc:
                    w = _value(ref[r["vehicle"]], q) if r["vehicle"] in ref else None
                    if w is None or not w[3] or not w[0]:
                        continue
                    comb = math.hypot(v[1] or 0.0, w[1] or 0.0)
                    pairs.append((100.0 * (v[0] - w[0]) / w[0], (v[0] - w[0]) / comb if comb else None))
            d = [p[0] for p in pairs]
            zc = [p[1] for p in pairs if p[1] is not None]
            out.append(
                {
                    "parameter": q,
                    "label": LABEL[q],
                    "source": name,
                    "missions": len(sub),
                    "not_identifiable": n_ni,
                    "estimated": len(vals),
                    "accepted": len(acc),
                    "error_pct": _stats(errs),
                    "z": {k: v for k, v in _stats(z).items() if k in ("n", "mean", "sd")},
                    "silently_wrong": sorted(int(r["index"]) for r in wrong),
                    "vs_reference": None
                    if name == REFERENCE
                    else {
                        "pairs": len(pairs),
                        "diff_pct": _stats(d),
                        "z": {k: v for k, v in _stats(zc).items() if k in ("n", "mean", "sd")},
                        "beyond_3_combined_sd": sum(1 for x in zc if abs(x) > 3.0),
                    },
                }
            )
    return {
        "reference": REFERENCE,
        "sources": names,
        "vehicles": len({r["vehicle"] for r in rows}),
        "rows": out,
    }


def by_source_table(bs):
    """campaign.md's table of by_source."""
    head = [
        "parameter",
        "source",
        "estimated",
        "accepted",
        "err mean %",
        "max |err| %",
        "z sd",
        "silently wrong",
        f"pairs with {source_words(bs['reference'])}",
        "diff mean %",
        "max |diff| %",
        "diff / combined sd: sd",
        "beyond 3 combined sd",
    ]
    rows = []
    for x in bs["rows"]:
        e, v = x["error_pct"], x["vs_reference"]
        est = str(x["estimated"])
        if x["not_identifiable"]:
            est = f"not identifiable ({x['not_identifiable']})" + (
                f", {x['estimated']}" if x["estimated"] else ""
            )
        row = [
            x["label"],
            source_words(x["source"]) if x["source"] != "not stated" else x["source"],
            est,
            str(x["accepted"]),
            _g(e["mean"], "{:+.3f}"),
            _g(e["max_abs"], "{:.3f}"),
            _g(x["z"]["sd"], "{:.2f}"),
            str(len(x["silently_wrong"])),
            "reference" if v is None else str(v["pairs"]),
            "-" if v is None else _g(v["diff_pct"]["mean"], "{:+.3f}"),
            "-" if v is None else _g(v["diff_pct"]["max_abs"], "{:.3f}"),
            "-" if v is None else _g(v["z"]["sd"], "{:.2f}"),
            "-" if v is None else str(v["beyond_3_combined_sd"]),
        ]
        if not x["estimated"]:  # nothing to judge: not identifiable under this source
            row[3:] = ["-"] * (len(row) - 3)
        rows.append(row)
    return head, rows


def _score(row, spec, only=None):
    """How far the mission's worst estimate (of the quantities `only`, default all) is from its
    truth, in tolerances: (score, quantity)."""
    best = (0.0, None)
    for q in only or QUANTITIES + (RATIO,):
        e = _f(row.get(f"{q}_error_pct"))
        if e is not None:
            s = abs(e) / spec["tolerance_pct"][q]
            if s > best[0]:
                best = (s, q)
    return best


def _expect(spec, rows, per, silently):
    out = []
    n_fail = sum(1 for r in rows if r["status"] not in RAN)
    for k, v in spec["expect"].items():
        q, what = expect_key(k)
        if what == "silently_wrong":
            got, ok = len(silently), len(silently) <= v
        elif what == "failures":
            got, ok = n_fail, n_fail <= v
        elif what == "acceptance" and q is None:  # the lowest acceptance rate of any quantity
            rates = [p["acceptance_rate"] for p in per.values() if p["acceptance_rate"] is not None]
            got = min(rates) if rates else None
            ok = got is not None and got >= v
        elif what == "error_pct":
            got = per[q]["error_pct_accepted"]["max_abs"]
            ok = got is not None and got <= v
        else:  # PARAM_acceptance
            got = per[q]["acceptance_rate"]
            ok = got is not None and got >= v
        op = ">=" if what == "acceptance" else "<="
        out.append({"key": k, "op": op, "limit": v, "value": got, "ok": bool(ok)})
    return out


def _g(x, fmt="{:.4g}"):
    return "-" if x is None else fmt.format(x)


def figures(out, per):
    """error_pct.png, z_hist.png, z_qq.png in `out`; returns their names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    nd = statistics.NormalDist()

    def save(fig, name):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=90)
        plt.close(fig)
        atomic_write(out / name, buf.getvalue(), mode="wb")
        names.append(name)

    fig, axes = plt.subplots(1, len(QUANTITIES), figsize=(3.2 * len(QUANTITIES), 3))
    for ax, q in zip(axes, QUANTITIES):
        e = per[q]["_err"]
        if e:
            ax.hist(e, bins=min(30, max(5, len(e) // 3)))
        for s in (-1, 1):
            ax.axvline(s * per[q]["tolerance_pct"], color="r", ls="--", lw=1)
        ax.set_title(f"{LABEL[q]}: error of accepted (%)")
        ax.set_xlabel("error %")
    fig.tight_layout()
    save(fig, "error_pct.png")

    fig, axes = plt.subplots(1, len(QUANTITIES), figsize=(3.2 * len(QUANTITIES), 3))
    xs = [i / 20.0 for i in range(-80, 81)]
    for ax, q in zip(axes, QUANTITIES):
        z = per[q]["_z"]
        if z:
            ax.hist(z, bins=min(30, max(5, len(z) // 3)), density=True, alpha=0.7)
        ax.plot(xs, [nd.pdf(x) for x in xs], "k-", lw=1, label="N(0, 1)")
        ax.set_title(f"{LABEL[q]}: (est - truth) / sd")
        ax.legend(fontsize=7)
    fig.tight_layout()
    save(fig, "z_hist.png")

    fig, axes = plt.subplots(1, len(QUANTITIES), figsize=(3.2 * len(QUANTITIES), 3))
    for ax, q in zip(axes, QUANTITIES):
        z = sorted(per[q]["_z"])
        n = len(z)
        if n:
            theo = [nd.inv_cdf((k + 0.5) / n) for k in range(n)]
            ax.plot(theo, z, ".", ms=4)
            lim = max(3.0, max(abs(v) for v in theo))
            ax.plot([-lim, lim], [-lim, lim], "k-", lw=1)
        ax.set_title(f"{LABEL[q]}: QQ vs N(0, 1)")
        ax.set_xlabel("normal quantile")
        ax.set_ylabel("z")
    fig.tight_layout()
    save(fig, "z_qq.png")
    return names


def write(out, spec, rows, columns, throughput, replay):
    """campaign.json, campaign.md and the figures; returns {"ok", "lines"} (the summary printed)."""
    ran, per, silently, failures = analyse(spec, rows)
    rows_by_index = {int(r["index"]): r for r in rows}
    worst = []
    wrong_q = {}
    for s_ in silently:
        wrong_q.setdefault(s_["index"], []).append(s_["parameter"])
    wrong_idx = set(wrong_q)
    # silently wrong missions first (ranked by their silently wrong estimates), then the rest
    ranked = sorted(
        (r for r in ran if int(r["index"]) in wrong_idx),
        key=lambda r: -_score(r, spec, wrong_q[int(r["index"])])[0],
    )
    ranked += sorted((r for r in ran if int(r["index"]) not in wrong_idx), key=lambda r: -_score(r, spec)[0])
    for r in ranked[:WORST]:
        s, q = _score(r, spec, wrong_q.get(int(r["index"])))
        if q is None:
            continue
        worst.append(
            {
                "index": int(r["index"]),
                "seed": int(r["seed"]),
                "status": r["status"],
                "parameter": q,
                "error_pct": _f(r[f"{q}_error_pct"]),
                "accepted": r[f"{q}_accepted"] == "1",
                "silently_wrong": q in wrong_q.get(int(r["index"]), ()),
                "command": replay(int(r["index"]), int(r["seed"])),
            }
        )
    not_ran = [
        {
            "index": int(r["index"]),
            "seed": int(r["seed"]),
            "status": r["status"],
            "reason": r["reason"],
            "command": replay(int(r["index"]), int(r["seed"])),
        }
        for r in rows
        if r["status"] not in RAN
    ]
    expect = _expect(spec, rows, per, silently)
    complete = len(rows_by_index) == flights(spec)
    all_ran = complete and not not_ran
    ok = all_ran and all(e["ok"] for e in expect)
    walls = [_f(r["wall_s"]) for r in rows if _f(r["wall_s"]) is not None]
    throughput = dict(throughput, mission_wall_s_mean=statistics.fmean(walls) if walls else None)
    figs = figures(out, per)
    by_group = groups(spec, rows)
    bs = by_source(spec, rows)
    doc = {
        "name": spec["name"],
        "missions": flights(spec),
        "in_results": len(rows_by_index),
        "ran": len(ran),
        "status_counts": dict(Counter(r["status"] for r in rows)),
        "silently_wrong": len(silently),
        "silently_wrong_list": silently,
        "parameters": {q: {k: v for k, v in p.items() if not k.startswith("_")} for q, p in per.items()},
        "failures": dict(failures.most_common()),
        "worst": worst,
        "not_ran": not_ran,
        "expect": expect,
        "sources": sources(rows),
        "builds": counts(rows, "build"),
        "sensors": counts(rows, "sensors"),
        "by_build_and_sensors": [{k: v for k, v in g.items() if not k.startswith("_")} for g in by_group],
        "by_source": bs,
        "throughput": throughput,
        "all_ran": all_ran,
        "ok": ok,
        "figures": figs,
        "spec": spec,
    }
    atomic_write(out / "campaign.json", json.dumps(doc, indent=1) + "\n")
    md = markdown(doc, per, by_group)
    atomic_write(out / "campaign.md", md)
    lines = summary_lines(doc, per, out)
    return {"ok": ok, "lines": lines, "doc": doc}


def table(per):
    head = [
        "parameter",
        "estimated",
        "accepted",
        "err mean %",
        "err sd %",
        "err RMS %",
        "max |err| %",
        "z mean",
        "z sd",
        "silently wrong",
    ]
    rows = []
    for q, p in per.items():
        e, z = p["error_pct_accepted"], p["z"]
        rows.append(
            [
                p["label"],
                str(p["estimated"]),
                f"{p['accepted']} ({_g(p['acceptance_rate'] and 100 * p['acceptance_rate'], '{:.0f}')} %)",
                _g(e["mean"], "{:+.3f}"),
                _g(e["sd"], "{:.3f}"),
                _g(e["rms"], "{:.3f}"),
                _g(e["max_abs"], "{:.3f}"),
                _g(z["mean"], "{:+.2f}"),
                _g(z["sd"], "{:.2f}"),
                str(len(p["silently_wrong"])),
            ]
        )
    return head, rows


def _md_table(head, rows):
    def cells(r):
        return "| " + " | ".join(str(x).replace("|", "\\|") for x in r) + " |"

    out = [cells(head), "|" + "---|" * len(head)]
    out += [cells(r) for r in rows]
    return out


def markdown(doc, per, by_group=()):
    t = doc["throughput"]
    L = [
        f"# Campaign {doc['name']}",
        "",
        f"**SILENTLY WRONG: {doc['silently_wrong']}** (accepted with |error| > max(3 sd, tolerance))",
        "",
        f"{doc['in_results']} of {doc['missions']} missions in results.csv; {doc['ran']} ran to a report; "
        + ", ".join(f"{k} {v}" for k, v in sorted(doc["status_counts"].items()))
        + ".",
        "",
    ]
    L += _md_table(*table(per))
    L += [
        "",
        "Errors are of the accepted estimates, percent of truth; z = (estimate - truth) / sd over every "
        "estimate (a standard normal when the sd is honest).",
        "",
    ]
    if doc.get("sources"):
        L += [
            "Estimated from: "
            + ", ".join(
                f"{source_words(src) if src != 'not stated' else src} ({n})"
                for src, n in doc["sources"].items()
            )
            + ".",
            "",
        ]
    if doc.get("builds"):
        L += [
            "Firmware builds: "
            + ", ".join(f"{b} ({n})" for b, n in doc["builds"].items())
            + "; sensors served: "
            + ", ".join(f"{x} ({n})" for x, n in doc.get("sensors", {}).items())
            + ".",
            "",
        ]
    bs = doc.get("by_source")
    if bs and bs["rows"]:
        L += [
            "## Sources side by side (the same vehicles)",
            "",
            f"{bs['vehicles']} vehicles, each flown with every sensor set; by the source the "
            "firmware used: "
            + ", ".join(source_words(x) if x != "not stated" else x for x in bs["sources"])
            + f". Each source's estimates against the truth (errors of the accepted, z = (estimate - "
            f"truth) / sd over every estimate), and against the same vehicle's {source_words(bs['reference'])} "
            "estimate where both were accepted: their difference in percent of it and over "
            "the combined sd sqrt(sd^2 + sd_ref^2). k_tau/I_z of the thrust rows is their k_tau over "
            "their I_z. Not identifiable: the missions whose source cannot determine the quantity "
            "alone (reported as such, no value).",
            "",
        ]
        L += _md_table(*by_source_table(bs))
        L += [""]
    if by_group:
        L += ["## By build and sensors", ""]
    for g in by_group:
        src = ", ".join(
            f"{source_words(x) if x != 'not stated' else x} ({n})" for x, n in g["sources"].items()
        )
        L += [
            f"### Build {g['build']}, sensors {g['sensors']}",
            "",
            f"{g['missions']} missions, {g['ran']} ran to a report, {g['silently_wrong']} silently wrong; "
            f"estimated from: {src or 'none'}.",
            "",
        ]
        L += _md_table(*table(g["_per"]))
        L += [""]
    L += ["## Acceptance and rejection reasons", ""]
    for q, p in per.items():
        rs = ", ".join(f"{why} ({n})" for why, n in p["rejection_reasons"].items()) or "none"
        L.append(f"- {p['label']}: {p['accepted']} of {p['estimated']} accepted; rejected: {rs}")
    if doc["failures"]:
        L += ["", "## Missions that did not run to a report", ""]
        L += [f"- {n} x {why}" for why, n in doc["failures"].items()]
    if doc["silently_wrong_list"]:
        L += ["", "## Silently wrong", ""]
        L += [
            f"- mission {s['index']} (seed {s['seed']}): {LABEL[s['parameter']]} error {_g(s['error_pct'], '{:+.3f}')} %, "
            f"sd {_g(s['sd_pct'], '{:.3f}')} %"
            for s in doc["silently_wrong_list"]
        ]
    L += [
        "",
        "## Worst missions",
        "",
        "Largest error relative to the tolerance; each replays with its command.",
        "",
    ]
    for w in doc["worst"]:
        L += [
            f"- mission {w['index']} (seed {w['seed']}, {w['status']}): {LABEL[w['parameter']]} error "
            f"{_g(w['error_pct'], '{:+.3f}')} % ({'accepted' if w['accepted'] else 'rejected'}"
            f"{', SILENTLY WRONG' if w['silently_wrong'] else ''})",
            f"  `{w['command']}`",
        ]
    for w in doc["not_ran"][:WORST]:
        L += [
            f"- mission {w['index']} (seed {w['seed']}): {w['status']}: {w['reason']}",
            f"  `{w['command']}`",
        ]
    if doc["expect"]:
        L += ["", "## Expectations", ""]
        L += [
            f"- {e['key']} = {_g(e['value'])} (must be {e['op']} {e['limit']:g}): {'ok' if e['ok'] else 'NOT MET'}"
            for e in doc["expect"]
        ]
    L += [
        "",
        "## Throughput",
        "",
        f"{t['missions_this_run']} missions in {t['missions_s']:.1f} s on {t['workers']} workers "
        f"({t['wall_s']:.1f} s with the cluster's start)"
        f" ({_g(t['missions_per_min'], '{:.2f}')} missions/min; a mission {_g(t['mission_wall_s_mean'], '{:.1f}')} s "
        f"wall, {_g(t.get('mission_cpu_s_mean'), '{:.2f}')} s CPU on its worker, on average); plant {t['plant']}.",
        "",
    ]
    L += [f"![{n}]({n})" for n in doc["figures"]]
    return "\n".join(L) + "\n"


def summary_lines(doc, per, out):
    head, rows = table(per)
    w = [max(len(x) for x in col) for col in zip(head, *rows)]
    fmt = "  ".join("{:<%d}" % n for n in w)
    lines = ["", fmt.format(*head)] + [fmt.format(*r) for r in rows] + [""]
    lines.append(f"SILENTLY WRONG: {doc['silently_wrong']}")
    for e in doc["expect"]:
        lines.append(
            f"expect {e['key']} {e['op']} {e['limit']:g}: {_g(e['value'])} {'ok' if e['ok'] else 'NOT MET'}"
        )
    verdict = "PASS" if doc["ok"] else "FAIL"
    why = "" if doc["all_ran"] else f" ({doc['missions'] - doc['ran']} missions did not run to a report)"
    lines.append(f"{verdict}{why}: {out}/campaign.md, campaign.json, results.csv")
    return lines
