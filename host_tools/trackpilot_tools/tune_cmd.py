"""`trackpilot tune LOG...`: identify the boat, the pilot and the compass from a commissioning trial's
log and write a tuned configuration with its margins (docs/COMMISSIONING.md).

Output folder (fresh, whole or marked partial):
    fit.json     every fitted value with its 1-sigma uncertainty; `sim_params` for `sim --boat`
    config.json  the firmware settings derived from the fit (install: `trackpilot upload --config`)
    report.md    the fits, the margins, what to repeat if anything was too uncertain
    *.png        each fit against the data
"""
import json
import math
import sys
from pathlib import Path

from trackpilot_tools.errors import UserError


def add_parser(p):
    p.add_argument("logs", nargs="+", metavar="LOG", help="firmware log files (.tpl) of the trial")
    p.add_argument("--out", default="tune_out", help="output folder (default tune_out)")
    p.add_argument("--length-m", type=float, default=5.0, help="the boat's length for K', T' (default 5.0)")
    p.add_argument("--gnss-latency-ms", type=float, default=75.0,
                   help="GNSS output latency, heading epoch to log record (default 75 ms, ZED-F9P at 5 Hz)")
    p.add_argument("--margin-deg", type=float, default=50.0,
                   help="phase margin the derived lookahead must keep (default 50 deg)")
    p.add_argument("--force", action="store_true",
                   help="write the configuration even when a fit is too uncertain (marked in the report)")
    p.add_argument("--no-plots", action="store_true")
    p.set_defaults(func=run)


def _clean(o):
    """JSON-able copy without the private (_...) parts."""
    if isinstance(o, dict):
        return {str(k): _clean(v) for k, v in o.items() if not str(k).startswith("_")}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    if hasattr(o, "item"):
        o = o.item()
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o


def run(args):
    from trackpilot_tools import logdecode
    from trackpilot_tools import tune_fit as F
    from trackpilot_tools.outdir import fresh_output

    for p in args.logs:
        if not Path(p).is_file():
            raise UserError("no such log file: %s" % p)
    if not args.length_m > 0:
        raise UserError("--length-m must be > 0")
    try:
        d = logdecode.decode_files(args.logs)
    except logdecode.LogError as e:
        raise UserError(str(e))
    try:
        fit = F.fit_all(d, args.length_m, args.gnss_latency_ms / 1000.0, args.margin_deg)
    except F.TuneError as e:
        raise UserError("cannot tune from this log: %s" % e)
    if fit["problems"] and not args.force:
        raise UserError("fits too uncertain to use: " + "; ".join(fit["problems"]) +
                        " (--force writes the configuration anyway)")
    err = _config_errors(fit["config"])
    if err:
        raise UserError("the derived configuration does not validate: %s" % "; ".join(err))
    with fresh_output(args.out) as out:
        (out / "fit.json").write_text(json.dumps(_clean(fit), indent=1))
        (out / "config.json").write_text(json.dumps(fit["config"], indent=2))
        plots = [] if args.no_plots else plot_fits(fit, out)
        (out / "report.md").write_text(report_text(fit, plots, args))
    out = Path(args.out)
    print((out / "report.md").read_text())
    print("output folder: %s (fit.json, config.json, report.md%s)" % (out, ", plots" if plots else ""))
    return 0


def _config_errors(partial):
    from trackpilot_tools.sim.runner import _fw_import

    _fw_import()
    from trackpilot import config as fwconfig

    return fwconfig.validate(partial)


def _pm(v, sd, fmt="%.3g"):
    if sd is None or not math.isfinite(sd):
        return (fmt % v) + " (uncertainty unknown)"
    return (fmt + " +- " + fmt) % (v, sd)


def report_text(fit, plots, args):
    n, c, ci, cur, sm, st, zz = (fit["nomoto"], fit["compass"], fit["circle"], fit["current"],
                                 fit["speed_map"], fit["steps"], fit["zigzag"])
    mg = fit["margins"]
    L = []
    L.append("# Commissioning trial: fit and tuned configuration\n")
    L.append("Logs: %s  \nTrial: %.0f s, %d manoeuvres. Uncertainties are 1 sigma.\n" % (
        ", ".join(args.logs), fit["trial"]["duration_s"], len(fit["trial"]["manoeuvres"])))
    if fit["problems"]:
        L.append("**TOO UNCERTAIN (written with --force):** " + "; ".join(fit["problems"]) + "\n")
    for w in fit.get("warnings", ()):
        L.append("Note: %s.\n" % w)
        L.append("## Boat (Nomoto, L = %.1f m)\n" % n["length_m"])
    L.append("| quantity | value |\n|---|---|")
    L.append("| K' | %s |" % _pm(n["k_prime"], n["k_prime_sd"]))
    L.append("| T' | %s |" % _pm(n["t_prime"], n["t_prime_sd"]))
    L.append("| rudder flow lag | %s s |" % _pm(n["rudder_lag_s"], n["rudder_lag_sd_s"], "%.2f"))
    L.append("| heading fit RMS | %.2f deg over %d windows of 20 s |" % (n["rms_deg"], n["windows"]))
    L.append("| turning radius (circles, %.0f deg rudder) | %s m |" % (ci["rudder_deg"], _pm(ci["radius_m"], ci["radius_sd_m"], "%.2f")))
    L.append("| ... from K' at that rudder (check) | %.2f m |" % ci["radius_from_k_prime_m"])
    L.append("| current seen | %.2f m/s towards %.0f deg (+- %.2f) |" % (cur["speed_mps"], cur["to_deg"], cur["sd_mps"]))
    rows = ", ".join("%d RPM: %.2f m/s" % (r, s) for r, s in zip(sm["rpm"], sm["speed_mps"]))
    L.append("| RPM -> water speed | %s (rpm = %.1f + %.1f x speed) |" % (rows, sm["rpm_offset"], sm["rpm_per_mps"]))
    L.append("| speed time constant (RPM step, during the turn back: rough, not used) | %.1f s |" % sm["speed_tc_s"])
    L.append("\n## Pilot compass\n")
    L.append("| quantity | value |\n|---|---|")
    L.append("| lag | %s s |" % _pm(c["lag_s"], c["lag_sd_s"], "%.2f"))
    L.append("| offset (compass - GNSS heading) | %.1f deg, deviation %.1f sin h %+.1f cos h |" % (
        c["offset_deg"], c["dev_sin_deg"], c["dev_cos_deg"]))
    L.append("| residual RMS | %.2f deg over %d readings |" % (c["rms_deg"], c["readings"]))
    L.append("\n## Closed heading response (pilot + boat) to course steps\n")
    L.append("| RPM | steps | delay (10 %) s | time constant s | overshoot % | gain | steady error deg |")
    L.append("|---|---|---|---|---|---|---|")
    for rpm, s in sorted(st["by_rpm"].items()):
        L.append("| %d | %d%s | %s | %s | %s | %s | %s |" % (
            rpm, s["steps"], (" (%d not settled)" % s["unsettled"]) if s["unsettled"] else "",
            _pm(s["delay_s"], s["delay_s_sd"], "%.2f"), _pm(s["tc_s"], s["tc_s_sd"], "%.2f"),
            _pm(100 * s["overshoot"], 100 * s["overshoot_sd"] if math.isfinite(s["overshoot_sd"]) else None, "%.0f"),
            _pm(s["gain"], s["gain_sd"], "%.2f"), _pm(s["steady_err_deg"], s["steady_err_deg_sd"], "%.1f")))
    for rpm, peaks in sorted(zz["overshoot_deg"].items()):
        L.append("\nZig-zag at %d RPM, overshoot: %s deg (mean %.1f)." % (
            rpm, ", ".join("%.1f" % x for x in peaks), zz["mean_overshoot_deg"][rpm]))
    L.append("")
    L.append("## Tuned configuration (config.json)\n")
    L.append("```json\n%s\n```\n" % json.dumps(fit["config"], indent=2))
    L.append("Margin: the LOS path loop with the closed heading response measured at %d RPM ("
             "delay %.2f s, time constant %.2f s) has a phase margin of %.0f deg (target %.0f deg) "
             "at %.2f rad/s with lookahead gain %.1f." % (
                 mg["at_rpm"], mg["heading_delay_s"], mg["heading_tc_s"], mg["phase_margin_deg"],
                 mg["margin_target_deg"], mg["crossover_rad_s"], fit["config"]["guidance"]["los_lookahead_gain"]))
    L.append("The turning radius in the configuration is the measured one plus 2 sigma.\n")
    L.append("Predicted accuracy: not computed here. Sail the fitted boat in the simulator with the "
             "tuned configuration to see it: `trackpilot sim TRACK --boat fit.json --fw-config config.json`.\n")
    L.append("Install: `trackpilot upload --config config.json` (STANDBY only; validated on the board).\n")
    if plots:
        L.append("## Plots\n")
        for p in plots:
            L.append("- %s" % p)
    return "\n".join(L) + "\n"


def plot_fits(fit, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = []
    # Nomoto: the windows' measured heading against the model
    win, fits = fit["nomoto"]["_plot"]
    fig, ax = plt.subplots(figsize=(10, 4))
    for wi in range(win.W):
        tt = win.i0[wi] * win.dt + win.w[wi] * win.dt + wi * (win.n * win.dt + 2)
        ax.plot(tt, win.psi[wi], "k.", ms=2)
        ax.plot(tt, fits[wi], "r-", lw=1)
    ax.set_xlabel("window (20 s each, laid end to end)")
    ax.set_ylabel("heading change (deg)")
    ax.set_title("Nomoto fit: K'=%.3f T'=%.3f (black: GNSS heading, red: model)" % (
        fit["nomoto"]["k_prime"], fit["nomoto"]["t_prime"]))
    fig.tight_layout()
    fig.savefig(out / "nomoto_fit.png", dpi=90)
    plt.close(fig)
    names.append("nomoto_fit.png")
    # compass
    rt, comp, pred = fit["compass"]["_plot"]
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(rt, ((comp - pred + 180) % 360) - 180, "k.", ms=2)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("compass - model (deg)")
    ax.set_title("Compass: lag %.2f s, offset %.1f deg" % (fit["compass"]["lag_s"], fit["compass"]["offset_deg"]))
    fig.tight_layout()
    fig.savefig(out / "compass_fit.png", dpi=90)
    plt.close(fig)
    names.append("compass_fit.png")
    # steps
    fig, ax = plt.subplots(figsize=(8, 4))
    for rpm, dlt, ts, y in fit["steps"]["_plot"]:
        ax.plot(ts, y, lw=1, label="%d RPM %+.0f deg" % (rpm, dlt))
    ax.axhline(1.0, color="k", lw=0.5)
    ax.set_xlabel("time after the key (s)")
    ax.set_ylabel("heading change / step")
    ax.legend(fontsize=7)
    ax.set_title("Closed heading response to course steps")
    fig.tight_layout()
    fig.savefig(out / "steps.png", dpi=90)
    plt.close(fig)
    names.append("steps.png")
    # speed map
    sm = fit["speed_map"]
    fig, ax = plt.subplots(figsize=(5, 4))
    ax.errorbar(sm["rpm"], sm["speed_mps"], yerr=sm["speed_sd_mps"], fmt="ko")
    xs = np.array([0, max(sm["rpm"]) * 1.2])
    ax.plot(xs, (xs - sm["rpm_offset"]) / sm["rpm_per_mps"], "r-")
    ax.set_xlabel("RPM")
    ax.set_ylabel("water speed (m/s)")
    ax.set_title("RPM -> speed")
    fig.tight_layout()
    fig.savefig(out / "speed_map.png", dpi=90)
    plt.close(fig)
    names.append("speed_map.png")
    return names


if __name__ == "__main__":  # pragma: no cover
    sys.exit(run(None))
