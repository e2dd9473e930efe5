"""``octo-gcs takeoff`` and ``octo-gcs land``."""

from .common import add_connection_args


def register(sub):
    tp = sub.add_parser(
        "takeoff",
        help="arm, take off and wait for the hold",
        description="Arms the vehicle (retrying while it waits for X-Plane frames), "
        "takes off to --height and waits until it holds there.",
    )
    add_connection_args(tp)
    tp.add_argument("--height", type=float, default=10.0, metavar="M", help="take-off height (default 10)")
    tp.add_argument(
        "--wait",
        type=float,
        default=60.0,
        metavar="S",
        help="longest wait for the arming and the hold (default 60)",
    )
    tp.set_defaults(run=run)
    lp = sub.add_parser(
        "land",
        help="land and wait for the disarm after touch-down",
        description="Lands the vehicle and waits until it disarms on the ground.",
    )
    add_connection_args(lp)
    lp.add_argument(
        "--wait", type=float, default=60.0, metavar="S", help="longest wait for the touch-down (default 60)"
    )
    lp.set_defaults(run=run)


def run(args):
    from ..flight import Flight
    from ..link import MODE_NUMBERS, Vehicle

    with Vehicle(args.connect, timeout=args.timeout, signing_key=args.signing_key) as v:
        v.wait_heartbeat()
        fl = Flight(v)
        if args.command == "takeoff":
            if v.mode in (MODE_NUMBERS["HOLD"], MODE_NUMBERS["EXPERIMENT"]):
                print(f"already flying (mode {fl.mode_name()})")
                return 0
            fl.arm(timeout=args.wait)
            print("armed; taking off")
            fl.takeoff(args.height, timeout=args.wait)
            print(f"holding at {args.height:g} m")
        else:
            fl.land(timeout=args.wait)
            print("landed and disarmed")
    return 0
