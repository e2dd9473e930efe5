"""``octo-gcs identify``: experiments on a hovering vehicle, their results and checks."""

from .common import add_connection_args


def register(sub):
    ip = sub.add_parser(
        "identify",
        help="run identification experiments on a hovering vehicle and check the results",
        description="Starts identification experiments (MAV_CMD_USER_1) on a vehicle that hovers, "
        "shows their progress (phase, time, live estimates +/- std), reads the results from the ID_* "
        "parameters and the vehicle's OCTO_ID_RESULT messages and checks them: present, accepted, relative "
        "std within ID_RSD_MAX, applied to VEH_*, physically plausible; with --expect also the error "
        "against the truth. Exit status 0 = pass, 1 = fail.",
        epilog="experiments: 1 rotor coefficients (k_f, k_tau), 2 validation, 3 Ix, 4 Iy, 5 Iz, "
        "6 the full sequence (validation, rotor, validation, Ix, Iy, Iz)",
    )
    add_connection_args(ip)
    ip.add_argument(
        "--experiments",
        default="6",
        metavar="LIST",
        help="experiment numbers, comma-separated, run in order (default 6)",
    )
    ip.add_argument(
        "--expect",
        metavar="VEHICLE.json",
        help="the true vehicle (octo-sim's --vehicle format; absent keys = the paper's values)",
    )
    ip.add_argument(
        "--tol-rotor",
        type=float,
        default=0.3,
        metavar="PCT",
        help="with --expect: largest error of k_f and k_tau, percent (default 0.3)",
    )
    ip.add_argument(
        "--tol-inertia",
        type=float,
        default=2.0,
        metavar="PCT",
        help="with --expect: largest error of Ix, Iy, Iz, percent (default 2)",
    )
    ip.add_argument(
        "--time-factor",
        type=float,
        default=2.0,
        metavar="X",
        help="wall seconds allowed per planned experiment second, plus 30 s (default 2)",
    )
    ip.set_defaults(run=run)


def run(args):
    from .. import id_results, vehiclefile
    from ..base import MODE_NUMBERS, MODES, GcsError
    from ..checks import report_checks
    from ..experiments import EXPERIMENTS, parse_experiments, planned_sim_seconds
    from ..identify import run_experiment
    from ..link import Vehicle
    from ..progress import Progress

    experiments = parse_experiments(args.experiments)
    truth = None
    if args.expect:
        try:
            truth = vehiclefile.truth_of(vehiclefile.load(args.expect))
        except vehiclefile.VehicleFileError as e:
            raise GcsError(str(e)) from None
    prog = Progress()
    results = id_results.Collector()
    with Vehicle(args.connect, timeout=args.timeout, signing_key=args.signing_key) as v:
        v.wait_heartbeat()
        params = v.fetch_params()
        for e in experiments:
            if v.mode != MODE_NUMBERS["HOLD"]:
                raise GcsError(
                    f"vehicle is in mode {MODES.get(v.mode, v.mode)}, not HOLD: "
                    "experiments need a hovering vehicle (take off first)"
                )
            prog.say(f"experiment {e}: {EXPERIMENTS[e]}")
            wall = planned_sim_seconds(params, e) * args.time_factor + 30.0
            run_experiment(v, e, prog, timeout=wall, results=results)
        records = results.records()
        params, filled = id_results.merge(v.fetch_params(), records)
        if filled:
            print(f"note: the vehicle has no parameters {', '.join(filled)}: taken from its results")
    return report_checks(
        params,
        experiments,
        truth,
        args.tol_rotor,
        args.tol_inertia,
        verdicts=id_results.verdicts(records),
        source=id_results.estimator_source(records),
        ratio=id_results.ratio_verdict(records),
    )
