"""``octo-gcs``: command-line entry point of the ground-station tools."""

import argparse
import sys

from . import __version__


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="octo-gcs",
        description="Octo-SIL ground station: parameters, in-flight identification, "
        "the one-command mission, plots. Talks to octo-fw over MAVLink 2.",
    )
    p.add_argument("--version", action="version", version=f"octo-gcs {__version__}")
    p.add_subparsers(dest="command", metavar="COMMAND")
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
