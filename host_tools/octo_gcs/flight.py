"""Flying octo-fw over MAVLink: arm, take off, wait for the hold, land.

octo-fw reports its mode in HEARTBEAT.custom_mode (0 disarmed, 1 idle, 2 take-off,
3 hold, 4 experiment, 5 land) and announces every change with a STATUSTEXT
"Mode <NAME>"; link.Vehicle tracks both in arrival order (Vehicle.mode).
Commands are idempotent, so the retries here are safe.
"""

import time

from .link import MODE_NUMBERS, MODES, GcsError, mavlink, result_name


class Flight:
    """Take-off, hold, landing on top of a link.Vehicle. `alive()` is called while
    waiting and may raise (e.g. when a helper process died)."""

    def __init__(self, vehicle, alive=None):
        self.v = vehicle
        self.alive = alive or (lambda: None)

    @property
    def mode(self):
        return self.v.mode

    def mode_name(self):
        return MODES.get(self.v.mode, str(self.v.mode))

    def poll(self, timeout=0.05):
        """Reads what arrives for `timeout` s (modes, texts, values are noted)."""
        self.alive()
        self.v.recv(types=(), timeout=timeout)

    def command(self, cmd, *params, timeout=2.0):
        """COMMAND_LONG -> (MAV_RESULT, the vehicle's reason text or '')."""
        self.alive()
        t0 = time.time()
        r = self.v.command(cmd, *params, timeout=timeout)
        self.v.recv(types=(), timeout=0.02)  # the STATUSTEXT with a reason follows the ACK
        return r, self.v._last_text(since=t0)

    def wait_mode(self, modes, timeout, what, clock=None, stall=30.0):
        """Waits until the vehicle is in one of `modes`, for `timeout` s of wall time, or with
        `clock` (the simulated time, s, or None while unknown) `timeout` s of simulated time: in
        lockstep the plant runs at whatever rate the firmware's host allows (an emulated
        processor on a busy machine: below real time), and the vehicle's time is what its
        manoeuvre takes. The simulated time then standing still for `stall` s of wall time is
        an error of its own."""
        want = {MODE_NUMBERS[m] if isinstance(m, str) else m for m in modes}
        deadline = time.monotonic() + timeout
        t_sim0 = t_last = clock() if clock else None
        moved = time.monotonic()
        while self.v.mode not in want:
            now = time.monotonic()
            if clock is not None:
                t = clock()
                if t is not None and t != t_last:
                    t_last, moved = t, now
                    t_sim0 = t if t_sim0 is None else t_sim0
                over = t_sim0 is not None and t_last - t_sim0 > timeout
                if now - moved > stall:
                    raise GcsError(
                        f"{what}: the simulated time stood still for {stall:g} s of wall time"
                        + (f" at t={t_last:.2f} s" if t_last is not None else "")
                        + f" (vehicle in mode {self.mode_name()})"
                    )
                unit = " simulated"
            else:
                over, unit = now > deadline, ""
            if over:
                last = self.v._last_text()
                raise GcsError(
                    f"{what}: vehicle still in mode {self.mode_name()} after {timeout:g} s{unit}"
                    + (f" (last message: {last})" if last else "")
                )
            self.poll(0.05)

    def arm(self, timeout=10.0):
        """Arms as soon as the vehicle accepts (it refuses until it has X-Plane frames)."""
        deadline = time.monotonic() + timeout
        while True:
            r, why = self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            if r == mavlink.MAV_RESULT_ACCEPTED:
                return
            if time.monotonic() > deadline:
                raise GcsError(f"vehicle refused to arm: {result_name(r)} {why}".strip())
            self.poll(0.1)

    def takeoff(self, height, timeout=60.0, clock=None):
        """Takes off and waits for the hold (`timeout`, `clock`: wait_mode)."""
        r, why = self.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, height)
        if r != mavlink.MAV_RESULT_ACCEPTED:
            raise GcsError(f"take-off refused: {result_name(r)} {why}".strip())
        self.wait_mode({"HOLD"}, timeout, f"take-off to {height:g} m", clock=clock)

    def land(self, timeout=60.0, clock=None):
        """Lands and waits for the disarm after touch-down (`timeout`, `clock`: wait_mode)."""
        if self.v.mode == MODE_NUMBERS["DISARMED"]:
            return
        r, why = self.command(mavlink.MAV_CMD_NAV_LAND)
        if r != mavlink.MAV_RESULT_ACCEPTED:
            raise GcsError(f"landing refused: {result_name(r)} {why}".strip())
        self.wait_mode({"DISARMED"}, timeout, "landing", clock=clock)
