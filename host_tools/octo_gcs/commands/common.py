"""Options several commands share."""

import argparse

from ..base import DEFAULT_URL


def add_connection_args(p, again=False):
    """--connect, --signing-key, --timeout. again=True: the same options once more on a
    sub-action (``params get NAME --connect URL``), not overriding the parent's values."""
    kw = {"default": argparse.SUPPRESS} if again else {}
    p.add_argument(
        "--connect",
        metavar="URL",
        **(kw or {"default": DEFAULT_URL}),
        help=f"MAVLink connection, pymavlink syntax (default {DEFAULT_URL})",
    )
    p.add_argument(
        "--signing-key",
        metavar="FILE",
        **(kw or {"default": None}),
        help="MAVLink 2 signing key file: 64 hex digits (the key) or a passphrase "
        "(key = sha256 of the text, surrounding white space stripped); "
        "octo-fw --signing-key takes the same files",
    )
    p.add_argument(
        "--timeout",
        type=float,
        metavar="S",
        **(kw or {"default": 5.0}),
        help="seconds to wait for the vehicle's answers (default 5)",
    )
