"""``octo-gcs plot LOG...``: the report's figures from existing LCM logs."""

import os

from ..base import GcsError


def register(sub):
    pl = sub.add_parser(
        "plot",
        help="the report's figures from existing LCM logs",
        description="Draws fig5_excitation.png, fig6_validation.png, fig7_rates.png and convergence.png "
        "from LCM logs of octo-fw (OCTO_FW_FRAME/EVENT) and, if given, octo-sim (OCTO_TRUTH). The model "
        "of Fig. 7 uses the parameters in use at the end of the firmware log, or those of --params.",
    )
    pl.add_argument("logs", nargs="+", metavar="LOG", help="LCM log files, or directories holding *.lcm")
    pl.add_argument("--out", default=".", metavar="DIR", help="where the figures go (default .)")
    pl.add_argument(
        "--params", metavar="FILE", help="parameter file (default: params.parm in a LOG directory, if there)"
    )
    pl.set_defaults(run=run)


def params_from_logs(logs):
    """Vehicle parameters in use at the end of the firmware log (the applied estimates)."""
    p = {}
    fw = logs.fw
    if fw is not None and len(fw):
        p.update(
            {
                "VEH_KF": float(fw.kf[-1]),
                "VEH_KTAU": float(fw.ktau[-1]),
                "VEH_IXX": float(fw.inertia[-1, 0]),
                "VEH_IYY": float(fw.inertia[-1, 1]),
                "VEH_IZZ": float(fw.inertia[-1, 2]),
                "VEH_MASS": float(fw.mass[-1]),
            }
        )
    if logs.truth is not None and len(logs.truth):
        p.setdefault("VEH_ARM_L", float(logs.truth.arm_length[-1]))
    return p


def run(args):
    from .. import paramfile
    from ..analysis import rate_comparison, validation
    from ..logs import Logs, find_logs
    from ..mission.report import truth_from_logs
    from ..plots import make_figures
    from ..vehiclefile import load

    logs = Logs(find_logs(args.logs))
    params = params_from_logs(logs)
    pfile = args.params
    if pfile is None:  # a mission's directory: its params.parm
        dirs = [d for d in args.logs if os.path.isdir(d) and os.path.exists(os.path.join(d, "params.parm"))]
        pfile = os.path.join(dirs[0], "params.parm") if dirs else None
    if pfile:
        try:
            params.update(paramfile.load(pfile))
        except (OSError, paramfile.ParamFileError) as e:
            raise GcsError(str(e)) from None
    rep = {"_params": params, "truth": truth_from_logs(logs, load(None)) if logs.truth is not None else {}}
    try:
        os.makedirs(args.out, exist_ok=True)
    except OSError as e:
        raise GcsError(f"cannot write {args.out}: {e.strerror}") from None
    rep["_rates"] = rate_comparison(logs, params)
    rep["_validation"] = validation(logs, params)
    names = make_figures(logs, rep, args.out)
    src = ("truth " if logs.truth is not None else "") + ("firmware" if logs.fw is not None else "")
    print(
        f"{len(names)} figures from the {src.strip().replace(' ', ' and ')} log(s) in {args.out}/: "
        + ", ".join(names)
    )
    for kind, _t, _w, _wm, fits in rep["_rates"]:
        print(
            f"  rates vs model during the {kind} experiment: fit "
            + ", ".join(f"{ax} {f:.1f} %" for ax, f in zip(("wx", "wy", "wz"), fits))
        )
    return 0
