"""``octo-gcs``: command-line entry point of the ground-station tools."""

import argparse
import sys

from . import __version__


def add_connection_args(p, again=False):
    """--connect, --signing-key, --timeout. again=True: the same options once more on a
    sub-action (``params get NAME --connect URL``), not overriding the parent's values."""
    from .base import DEFAULT_URL

    kw = {"default": argparse.SUPPRESS} if again else {}
    p.add_argument("--connect", metavar="URL", **(kw or {"default": DEFAULT_URL}),
                   help=f"MAVLink connection, pymavlink syntax (default {DEFAULT_URL})")
    p.add_argument("--signing-key", metavar="FILE", **(kw or {"default": None}),
                   help="MAVLink 2 signing key file: 64 hex digits (the key) or a passphrase "
                        "(key = sha256 of the text, surrounding white space stripped); "
                        "octo-fw --signing-key takes the same files")
    p.add_argument("--timeout", type=float, metavar="S", **(kw or {"default": 5.0}),
                   help="seconds to wait for the vehicle's answers (default 5)")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="octo-gcs",
        description="Octo-SIL ground station: parameters, in-flight identification, "
        "the one-command mission, plots. Talks to octo-fw over MAVLink 2.",
    )
    p.add_argument("--version", action="version", version=f"octo-gcs {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    pp = sub.add_parser("params", help="list, get, set, save, load, diff vehicle parameters",
                        description="Vehicle parameters over MAVLink. Files use MAVProxy's "
                        "'NAME VALUE' format.")
    add_connection_args(pp)
    psub = pp.add_subparsers(dest="action", metavar="ACTION", required=True)
    ls = psub.add_parser("list", help="print every parameter")
    g = psub.add_parser("get", help="print one parameter")
    g.add_argument("name")
    s = psub.add_parser("set", help="set one parameter and check the vehicle's echo")
    s.add_argument("name")
    s.add_argument("value", type=float)
    sv = psub.add_parser("save", help="save all parameters to FILE (atomically)")
    sv.add_argument("file")
    ld = psub.add_parser("load", help="set the parameters of FILE that differ on the vehicle")
    ld.add_argument("file")
    df = psub.add_parser("diff", help="show parameters that differ between the vehicle and FILE")
    df.add_argument("file")
    for action in (ls, g, s, sv, ld, df):
        add_connection_args(action, again=True)

    tp = sub.add_parser("takeoff", help="arm, take off and wait for the hold",
                        description="Arms the vehicle (retrying while it waits for X-Plane frames), "
                        "takes off to --height and waits until it holds there.")
    add_connection_args(tp)
    tp.add_argument("--height", type=float, default=10.0, metavar="M", help="take-off height (default 10)")
    tp.add_argument("--wait", type=float, default=60.0, metavar="S",
                    help="longest wait for the arming and the hold (default 60)")
    lp = sub.add_parser("land", help="land and wait for the disarm after touch-down",
                        description="Lands the vehicle and waits until it disarms on the ground.")
    add_connection_args(lp)
    lp.add_argument("--wait", type=float, default=60.0, metavar="S",
                    help="longest wait for the touch-down (default 60)")

    ip = sub.add_parser(
        "identify", help="run identification experiments on a hovering vehicle and check the results",
        description="Starts identification experiments (MAV_CMD_USER_1) on a vehicle that hovers, "
        "shows their progress (phase, time, live estimates +/- std), reads the results from the ID_* "
        "parameters and checks them: present, accepted, relative std within ID_RSD_MAX, applied to "
        "VEH_*, physically plausible; with --expect also the error against the truth. "
        "Exit status 0 = pass, 1 = fail.",
        epilog="experiments: 1 rotor coefficients (k_f, k_tau), 2 validation, 3 Ix, 4 Iy, 5 Iz, "
        "6 the full sequence (validation, rotor, validation, Ix, Iy, Iz)")
    add_connection_args(ip)
    ip.add_argument("--experiments", default="6", metavar="LIST",
                    help="experiment numbers, comma-separated, run in order (default 6)")
    ip.add_argument("--expect", metavar="VEHICLE.json",
                    help="the true vehicle (octo-sim's --vehicle format; absent keys = the paper's values)")
    ip.add_argument("--tol-rotor", type=float, default=0.3, metavar="PCT",
                    help="with --expect: largest error of k_f and k_tau, percent (default 0.3)")
    ip.add_argument("--tol-inertia", type=float, default=2.0, metavar="PCT",
                    help="with --expect: largest error of Ix, Iy, Iz, percent (default 2)")
    ip.add_argument("--time-factor", type=float, default=2.0, metavar="X",
                    help="wall seconds allowed per planned experiment second, plus 30 s (default 2)")

    mp = sub.add_parser(
        "mission", help="the whole job: start octo-sim and octo-fw, fly, identify, report",
        description="Starts octo-sim (lockstep unless --realtime) and octo-fw on free ports, both logging "
        "to LCM files; sets VEH_MASS and VEH_ARM_L from the vehicle file; arms, takes off to 10 m, runs "
        "the identification, collects every parameter over MAVLink, lands and stops both programs (also "
        "on errors and Ctrl-C). Writes DIR: report.md, report.json, params.parm, truth.lcm and fw.lcm, "
        "octo-sim.log and octo-fw.log, fig5_excitation.png, fig6_validation.png, fig7_rates.png, "
        "convergence.png. Exit status 0 when every check passes.")
    mp.add_argument("--vehicle", metavar="FILE",
                    help="the simulated vehicle, octo-sim's JSON format (default: the paper's vehicle)")
    mp.add_argument("--seed", type=int, default=1, metavar="N", help="seed of the noise and excitation (1)")
    mp.add_argument("--out", default="out", metavar="DIR", help="output directory (default out)")
    mp.add_argument("--realtime", action="store_true",
                    help="run octo-sim in real time like X-Plane (default: lockstep, as fast as possible)")
    mp.add_argument("--xplane-version", type=int, choices=(11, 12), default=12,
                    help="X-Plane protocol personality of octo-sim (default 12)")
    mp.add_argument("--experiments", default="6", metavar="LIST",
                    help="experiments to run (default 6, the full sequence; 'none' only flies)")
    mp.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="set a vehicle parameter before the flight, e.g. ID_INR_TIME=20 (repeatable)")
    mp.add_argument("--build-dir", metavar="DIR",
                    help="where octo-sim and octo-fw are (default $OCTO_BUILD, else the repository's build/)")
    mp.add_argument("--no-plots", dest="plots", action="store_false", help="skip the figures")
    mp.add_argument("--in-process", action="store_true",
                    help="fly in octo-sil (firmware and plant in one deterministic lockstep process; "
                    "parameters from its parameter file) instead of octo-sim + octo-fw over UDP")
    mp.add_argument("--timeout", type=float, default=5.0, metavar="S",
                    help="seconds to wait for the vehicle's answers (default 5)")

    cp = sub.add_parser(
        "campaign", help="Monte Carlo missions over vehicles, seeds, faults and parameters, on Dask",
        description="Runs SPEC.json's missions (octo-gcs mission, one per Dask task) on a local Dask cluster "
        "or, with --scheduler, on an existing one. Mission i flies with seed S + i and its own draws. "
        "Writes DIR: results.csv (a row per mission as it ends), missions/NNNN/ (report.json, vehicle.json, "
        "mission.log), spec.json, and at the end campaign.md, campaign.json and figures. Exit status 0 when "
        "every mission ran and the spec's expect holds, 1 otherwise, 2 for a bad spec or options.",
        epilog="SPEC keys: name, missions, seed, vehicle {octo-sim keys}, faults {drop, burst, burst_prob, "
        "delay_frames, duplicate, reorder}, params {NAME: value}, experiments [6], plant in-process|udp, "
        "timeout (s per mission, 600), retries (2), tolerance_pct {kf: 0.3, ...}, expect {k_f_error_pct: 0.3, "
        "silently_wrong: 0, ...}. A value is a number or {\"uniform\": [lo, hi]}, {\"loguniform\": [lo, hi]}, "
        "{\"normal\": [mean, sd]}, {\"choice\": [...]}.")
    cp.add_argument("spec", metavar="SPEC.json", help="the campaign specification")
    cp.add_argument("--out", default="campaign", metavar="DIR", help="output directory (default campaign)")
    cp.add_argument("--scheduler", metavar="ADDRESS",
                    help="an existing Dask scheduler, tcp://HOST:PORT (default: a local cluster)")
    cp.add_argument("--workers", type=int, metavar="N",
                    help="worker processes of the local cluster (default: the number of cores)")
    cp.add_argument("--resume", action="store_true",
                    help="go on with DIR's campaign: skip the missions already in results.csv")

    pl = sub.add_parser(
        "plot", help="the report's figures from existing LCM logs",
        description="Draws fig5_excitation.png, fig6_validation.png, fig7_rates.png and convergence.png "
        "from LCM logs of octo-fw (OCTO_FW_FRAME/EVENT) and, if given, octo-sim (OCTO_TRUTH). The model "
        "of Fig. 7 uses the parameters in use at the end of the firmware log, or those of --params.")
    pl.add_argument("logs", nargs="+", metavar="LOG", help="LCM log files, or directories holding *.lcm")
    pl.add_argument("--out", default=".", metavar="DIR", help="where the figures go (default .)")
    pl.add_argument("--params", metavar="FILE",
                    help="parameter file (default: params.parm in a LOG directory, if there)")
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    from .base import GcsError
    from .procs import Terminated

    try:
        if args.command == "params":
            from .params_cmd import run
            return run(args)
        if args.command in ("takeoff", "land"):
            from .flight import run
            return run(args)
        if args.command == "identify":
            from .identify import run
            return run(args)
        if args.command == "mission":
            from .mission import run
            return run(args)
        if args.command == "campaign":
            from .campaign import run
            return run(args)
        if args.command == "plot":
            from .plot_cmd import run
            return run(args)
    except GcsError as e:
        print(f"octo-gcs: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("octo-gcs: interrupted", file=sys.stderr)
        return 130
    except Terminated as e:
        print(f"octo-gcs: stopped by {e}", file=sys.stderr)
        return 143
    return 0


if __name__ == "__main__":
    sys.exit(main())
