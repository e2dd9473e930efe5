"""``python -m octo_gcs``: the same command as ``octo-gcs``."""

import sys

from .cli import main

sys.exit(main())
