"""What every octo-gcs command shares without loading pymavlink: the error a user reads,
the default connection, octo-fw's mode numbers. link.py re-exports them; commands that
never open a MAVLink link (mission --in-process, plot) start faster for it."""

DEFAULT_URL = "udpin:0.0.0.0:14550"

# octo-fw's modes: HEARTBEAT.custom_mode, and the STATUSTEXT "Mode <NAME>" on each change
MODES = {0: "DISARMED", 1: "IDLE", 2: "TAKEOFF", 3: "HOLD", 4: "EXPERIMENT", 5: "LAND"}
MODE_NUMBERS = {v: k for k, v in MODES.items()}


class GcsError(RuntimeError):
    """A failure the user should read (no vehicle, no answer, refused write...)."""
