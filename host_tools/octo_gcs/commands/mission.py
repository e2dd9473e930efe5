"""``octo-gcs mission``: the whole identification flight in one command (octo_gcs.mission)."""


def register(sub):
    mp = sub.add_parser(
        "mission",
        help="the whole job: start octo-sim and octo-fw, fly, identify, report",
        description="Starts octo-sim (lockstep unless --realtime) and octo-fw on free ports, both logging "
        "to LCM files; sets VEH_MASS and VEH_ARM_L from the vehicle file; arms, takes off to 10 m, runs "
        "the identification, collects every parameter over MAVLink, lands and stops both programs (also "
        "on errors and Ctrl-C). Writes DIR: report.md, report.json, params.parm, truth.lcm and fw.lcm, "
        "octo-sim.log and octo-fw.log, fig5_excitation.png, fig6_validation.png, fig7_rates.png, "
        "convergence.png. Exit status 0 when every check passes.",
    )
    mp.add_argument(
        "--vehicle",
        metavar="FILE",
        help="the simulated vehicle, octo-sim's JSON format (default: the paper's vehicle)",
    )
    mp.add_argument("--seed", type=int, default=1, metavar="N", help="seed of the noise and excitation (1)")
    mp.add_argument("--out", default="out", metavar="DIR", help="output directory (default out)")
    mp.add_argument(
        "--realtime",
        action="store_true",
        help="run octo-sim in real time like X-Plane (default: lockstep, as fast as possible)",
    )
    mp.add_argument(
        "--xplane-version",
        type=int,
        choices=(11, 12),
        default=12,
        help="X-Plane protocol personality of octo-sim (default 12)",
    )
    mp.add_argument(
        "--experiments",
        default="6",
        metavar="LIST",
        help="experiments to run (default 6, the full sequence; 'none' only flies)",
    )
    mp.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="set a vehicle parameter before the flight, e.g. ID_INR_TIME=20 (repeatable)",
    )
    mp.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a fault of the plant's link (octo-sim's flags, a campaign spec's faults): drop, burst, "
        "burst_prob, delay_frames, duplicate, reorder; e.g. drop=0.02 (repeatable)",
    )
    mp.add_argument(
        "--fixed",
        action="store_true",
        help="fly the Q16.16 firmware build: octo-fw-fixed (with octo-sim), octo-sil-fixed with --in-process",
    )
    mp.add_argument(
        "--sensors",
        metavar="LIST",
        help="what the plant serves, comma-separated from imu, rpm, torque, thrust (default: all; "
        "octo-sim's --sensors); e.g. imu,rpm",
    )
    mp.add_argument(
        "--start-time",
        type=float,
        default=0.0,
        metavar="S",
        help="start the plant's clock at S seconds (octo-sim's --start-time): a long uptime in seconds (0)",
    )
    mp.add_argument(
        "--shift-origin",
        action="append",
        type=float,
        default=[],
        metavar="T",
        help="at plant time T s move the plant's local OpenGL origin as X-Plane does (repeatable)",
    )
    mp.add_argument(
        "--build-dir",
        metavar="DIR",
        help="where octo-sim and octo-fw (octo-sil, the -fixed builds) are (default $OCTO_BUILD, else the "
        "repository's build/)",
    )
    mp.add_argument("--no-plots", dest="plots", action="store_false", help="skip the figures")
    mp.add_argument(
        "--in-process",
        action="store_true",
        help="fly in octo-sil (firmware and plant in one deterministic lockstep process; "
        "parameters from its parameter file) instead of octo-sim + octo-fw over UDP",
    )
    mp.add_argument(
        "--timeout",
        type=float,
        default=5.0,
        metavar="S",
        help="seconds to wait for the vehicle's answers (default 5)",
    )
    mp.set_defaults(run=run)


def options(args):
    """The MissionOptions of the parsed command line."""
    from ..mission.options import (
        MissionOptions,
        experiments_option,
        fault_options,
        param_options,
        sensors_list,
    )

    return MissionOptions(
        plant="sil" if args.in_process else "udp",
        vehicle=args.vehicle,
        seed=args.seed,
        out=args.out,
        realtime=args.realtime,
        xplane_version=args.xplane_version,
        experiments=experiments_option(args.experiments),
        params=param_options(args.param),
        faults=fault_options(args.fault),
        build_dir=args.build_dir,
        plots=args.plots,
        timeout=args.timeout,
        build="fixed" if args.fixed else "float",
        sensors=sensors_list(args.sensors) if args.sensors is not None else None,
        start_time=args.start_time,
        shift_origin=list(args.shift_origin),
    )


def run(args):
    from ..mission.run import run as run_mission

    return run_mission(options(args))
