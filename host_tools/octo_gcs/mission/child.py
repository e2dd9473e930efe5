"""A mission in a child process: ``python -m octo_gcs.mission.child`` reads its MissionOptions
as JSON on stdin and prints and exits as ``octo-gcs mission`` does (a campaign's missions on
the UDP plant, each in its own process group)."""

import json
import sys

from ..base import GcsError
from ..procs import exit_status
from .options import MissionOptions
from .run import run


def main():
    def fly():
        try:
            opts = MissionOptions.from_json(json.load(sys.stdin))
        except ValueError as e:
            raise GcsError(f"mission options on stdin: {e}") from None
        return run(opts)

    return exit_status(fly)


if __name__ == "__main__":
    sys.exit(main())
