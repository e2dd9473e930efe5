"""``octo-gcs``: command-line entry point of the ground-station tools (the commands are in
octo_gcs.commands)."""

import argparse
import sys

from . import __version__
from .commands import register_all


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="octo-gcs",
        description="Octo-SIL ground station: parameters, in-flight identification, "
        "the one-command mission, plots. Talks to octo-fw over MAVLink 2.",
    )
    p.add_argument("--version", action="version", version=f"octo-gcs {__version__}")
    register_all(p.add_subparsers(dest="command", metavar="COMMAND"))
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    from .procs import exit_status

    return exit_status(lambda: args.run(args))


if __name__ == "__main__":
    sys.exit(main())
