"""octo-gcs's commands: each module registers its parser (`register(subparsers)`, which sets
the parsed arguments' `run`) and runs it (`run(args)` -> exit status). Their heavy imports
happen in `run`, so that building the parser stays fast."""

import importlib

# in the order of `octo-gcs --help`
MODULES = ("params", "flight", "identify", "mission", "campaign", "plot")


def register_all(subparsers):
    for name in MODULES:
        importlib.import_module(f"{__name__}.{name}").register(subparsers)
