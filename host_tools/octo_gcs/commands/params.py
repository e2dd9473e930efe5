"""``octo-gcs params``: list, get, set, save, load, diff."""

import sys

from .. import paramfile
from ..base import GcsError, f32
from .common import add_connection_args


def register(sub):
    pp = sub.add_parser(
        "params",
        help="list, get, set, save, load, diff vehicle parameters",
        description="Vehicle parameters over MAVLink. Files use MAVProxy's 'NAME VALUE' format.",
    )
    add_connection_args(pp)
    pp.set_defaults(run=run)
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


def _differs(a, b):
    return f32(a) != f32(b)


def diff(vehicle_params, file_params):
    """Rows (name, vehicle value or None, file value or None) where the two differ."""
    rows = []
    for name in sorted(set(vehicle_params) | set(file_params)):
        v, f = vehicle_params.get(name), file_params.get(name)
        if v is None or f is None or _differs(v, f):
            rows.append((name, v, f))
    return rows


def _fmt(v):
    return "-" if v is None else f"{v:g}"


def run(args) -> int:
    from ..link import Vehicle

    if args.action in ("load", "diff"):
        try:
            wanted = paramfile.load(args.file)
        except (OSError, paramfile.ParamFileError) as e:
            raise GcsError(str(e)) from None
    with Vehicle(args.connect, timeout=args.timeout, signing_key=args.signing_key) as v:
        v.wait_heartbeat()
        if args.action == "get":
            print(f"{args.name} {v.get_param(args.name):g}")
            return 0
        if args.action == "set":
            echoed = v.set_param(args.name, args.value)
            print(f"{args.name} {echoed:g}")
            return 0
        params = v.fetch_params()
        if args.action == "list":
            sys.stdout.write(paramfile.format_params(params))
            return 0
        if args.action == "save":
            paramfile.save(args.file, params)
            print(f"saved {len(params)} parameters to {args.file}")
            return 0
        if args.action == "diff":
            rows = diff(params, wanted)
            for name, a, b in rows:
                print(f"{name:<16} vehicle {_fmt(a):>12}  file {_fmt(b):>12}")
            print(f"{len(rows)} differ")
            return 0
        # load: set only what differs; report what changed and what was refused
        changed, refused = 0, 0
        for name, value in wanted.items():
            if name not in params:
                print(f"{name}: not on the vehicle, skipped")
                refused += 1
                continue
            if not _differs(params[name], value):
                continue
            try:
                v.set_param(name, value)
                print(f"{name}: {params[name]:g} -> {value:g}")
                changed += 1
            except GcsError as e:
                print(f"{name}: {e}")
                refused += 1
        print(f"loaded {args.file}: {changed} changed, {refused} refused or unknown")
        return 1 if refused else 0
