"""``octo-gcs``: command-line entry point of the ground-station tools."""

import argparse
import sys

from . import __version__


def add_connection_args(p):
    from .link import DEFAULT_URL

    p.add_argument("--connect", default=DEFAULT_URL, metavar="URL",
                   help=f"MAVLink connection, pymavlink syntax (default {DEFAULT_URL})")
    p.add_argument("--signing-key", metavar="FILE",
                   help="MAVLink 2 signing key: 64 hex digits, or a passphrase (key = its sha256)")
    p.add_argument("--timeout", type=float, default=5.0, metavar="S",
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
    psub.add_parser("list", help="print every parameter")
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
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    from .link import GcsError

    try:
        if args.command == "params":
            from .params_cmd import run
            return run(args)
    except GcsError as e:
        print(f"octo-gcs: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("octo-gcs: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
