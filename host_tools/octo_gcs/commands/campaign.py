"""``octo-gcs campaign SPEC.json``: Monte Carlo missions on Dask (octo_gcs.campaign)."""


def register(sub):
    cp = sub.add_parser(
        "campaign",
        help="Monte Carlo missions over vehicles, seeds, faults and parameters, on Dask",
        description="Runs SPEC.json's missions (octo-gcs mission, one per Dask task) on a local Dask cluster "
        "or, with --scheduler, on an existing one. Mission i flies with seed S + i and its own draws. "
        "Writes DIR: results.csv (a row per mission as it ends), missions/NNNN/ (report.json, vehicle.json, "
        "mission.log), spec.json, and at the end campaign.md, campaign.json and figures. Exit status 0 when "
        "every mission ran and the spec's expect holds, 1 otherwise, 2 for a bad spec or options.",
        epilog="SPEC keys: name, missions, seed, vehicle {octo-sim keys}, faults {drop, burst, burst_prob, "
        "delay_frames, duplicate, reorder}, params {NAME: value}, experiments [6], plant in-process|udp, "
        'build float|fixed, sensors (what the plant serves: "imu,rpm"; a list of such lists flies every '
        "vehicle with each, side by side in campaign.md), "
        "timeout (s per mission, 600), retries (2), tolerance_pct {kf: 0.3, ...}, expect {k_f_error_pct: 0.3, "
        'silently_wrong: 0, ...}. A value is a number or {"uniform": [lo, hi]}, {"loguniform": [lo, hi]}, '
        '{"normal": [mean, sd]}, {"choice": [...]}.',
    )
    cp.add_argument("spec", metavar="SPEC.json", help="the campaign specification")
    cp.add_argument("--out", default="campaign", metavar="DIR", help="output directory (default campaign)")
    cp.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="an existing Dask scheduler, tcp://HOST:PORT (default: a local cluster)",
    )
    cp.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="worker processes of the local cluster (default: the number of cores)",
    )
    cp.add_argument(
        "--resume",
        action="store_true",
        help="go on with DIR's campaign: skip the missions already in results.csv",
    )
    cp.set_defaults(run=run)


def run(args):
    from ..campaign import run as run_campaign

    return run_campaign(args)
