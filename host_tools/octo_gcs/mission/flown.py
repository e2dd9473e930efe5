"""What a flight gives the report, whichever the plant."""

from dataclasses import dataclass, field


@dataclass
class Flown:
    nominal: dict  # the parameters before identification (with what the mission set)
    after: dict  # the parameters after the flight, with the values only the results carry
    results: list  # the firmware's identification results (id_results.record dicts)
    filled: list = field(default_factory=list)  # names in `after` taken from the results, not parameters
    plant: str = ""  # report.json's run.plant
    logs: object = None  # the flight's logs.Logs when the flight read them already

    @property
    def params_only(self):
        """The parameters as the vehicle holds them (params.parm)."""
        return {k: v for k, v in self.after.items() if k not in self.filled}
