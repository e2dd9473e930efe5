"""The mission library: one identification flight from typed options to a report.

- options.py: MissionOptions (what `octo-gcs mission` and a campaign's missions take);
- staging.py: the output directory (a staging directory published whole, or kept as failed-run/);
- flying_udp.py: the flight with octo-sim and octo-fw over UDP and MAVLink (plant "udp");
- flying_sil.py: the flight in octo-sil, one lockstep process (plant "sil");
- report.py: the report (Table 1 beside the truth, the checks), report.md and report.json;
- run.py: a whole mission, options to exit status;
- child.py: a mission in a child process, its options as JSON on stdin (campaigns).
"""
