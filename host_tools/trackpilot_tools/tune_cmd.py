"""`trackpilot tune LOG...`: identify the boat, the pilot and the compass from a commissioning trial's
log and write a tuned configuration with its margins (docs/COMMISSIONING.md).

Output folder (fresh, whole or marked partial):
    fit.json     every fitted value with its 1-sigma uncertainty; `sim_params` for `sim --boat`
    config.json  the recommended firmware settings (install: `trackpilot upload --config`): the
                 tuned guidance, or with --sweep only where it is no worse than the defaults
    config_tuned.json  the settings derived from the fit, always
    sweep.json   with --sweep N: the robustness sweep around the fitted boat (tune_sweep.py)
    report.md    the fits, the margins, what to repeat if anything was too uncertain
    *.png        each fit against the data
"""
import json
import math
import sys
from pathlib import Path

from trackpilot_tools.errors import UserError


def add_parser(p):
    p.add_argument("logs", nargs="+", metavar="LOG", help="firmware log files (.tpl) of the trial; of several trials (in the order sailed): each fitted, then pooled")
    p.add_argument("--out", default="tune_out", help="output folder (default tune_out)")
    p.add_argument("--length-m", type=float, default=5.0, help="the boat's length for K', T' (default 5.0)")
    p.add_argument("--gnss-latency-ms", type=float, default=75.0,
                   help="GNSS output latency, heading epoch to log record (default 75 ms, ZED-F9P at 5 Hz)")
    p.add_argument("--sweep", type=int, default=0, metavar="N",
                   help="sail N boats around the fit (within its uncertainty) with the tuned and the default "
                        "guidance on Dask and recommend one (default 0: not checked; N = 20 takes about "
                        "N x 2 x 30 s of CPU)")
    p.add_argument("--jobs", type=int, default=1, help="Dask workers for --sweep (default 1)")
    p.add_argument("--scheduler", default=None, help="a running Dask scheduler for --sweep (tcp://HOST:8786)")
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
    from trackpilot_tools import tune_pool as P
    from trackpilot_tools.outdir import fresh_output

    for p in args.logs:
        if not Path(p).is_file():
            raise UserError("no such log file: %s" % p)
    if not 1.0 <= args.length_m <= 100.0:  # also false for NaN
        raise UserError("--length-m must be a boat's length in metres, 1 to 100 (got %s)" % args.length_m)
    if not 0.0 <= args.gnss_latency_ms <= 1000.0:
        raise UserError("--gnss-latency-ms must be 0 to 1000 ms (the ZED-F9P at 5 Hz: about 75; got %s)"
                        % args.gnss_latency_ms)
    if args.sweep < 0 or args.jobs < 1:
        raise UserError("--sweep must be >= 0 and --jobs >= 1")
    logs = _distinct_logs(args.logs)
    try:
        d = logdecode.decode_files(logs)
    except logdecode.LogError as e:
        raise UserError(str(e))
    try:
        fit = P.fit_trials(d, args.length_m, args.gnss_latency_ms / 1000.0)
    except F.TuneError as e:
        raise UserError("cannot tune from this log: %s" % e)
    if fit["problems"] and not args.force:
        hint = ""
        if (fit.get("pooled") or {}).get("trials", 1) < 2 and any(
                not p.startswith(("the pilot hunted", "trial ")) for p in fit["problems"]):
            # each trial's own noise and current walk: pooled, a second trial narrows them
            hint = (" Every complete trial in the logs given is fitted and pooled: a second whole trial "
                    "with this one usually brings them within the limits.")
        raise UserError("fits too uncertain to use: " + "; ".join(fit["problems"]) + "." + hint +
                        " (--force writes the configuration anyway)")
    err = _config_errors(fit["config"])
    if err:
        raise UserError("the derived configuration does not validate: %s" % "; ".join(err))
    fit["recommended"] = ("tuned", "NOT checked against the defaults: run tune with --sweep N")
    if args.sweep:
        from trackpilot_tools import tune_sweep as S

        if fit["sim_params"] is None:
            raise UserError("--sweep sails boats around the fitted one, and this fit has no K' and T' (%s): "
                            "run tune without --sweep" % fit["rudder"]["absent"])
        configs = {"tuned": fit["config"], "default": default_config(fit["config"])}
        print("sweep: %d boats around the fit x 2 configurations on Dask (%s)..." % (
            args.sweep, args.scheduler or "%d local worker(s)" % args.jobs), flush=True)
        res = S.run(fit, configs, args.sweep, workers=args.jobs, scheduler=args.scheduler)
        fit["sweep"] = {"boats": args.sweep, "summary": S.summarise(res),
                        "runs": [{"config": r["job"]["config"], "boat": r["job"]["boat"], "case": r["job"]["case"],
                                  "drawn": r.get("params"), "metrics": r["metrics"]}
                                 for rs in res.values() for r in rs]}
        fit["recommended"] = S.recommend(fit["sweep"]["summary"])
    chosen = fit["config"] if fit["recommended"][0] == "tuned" else default_config(fit["config"])
    with fresh_output(args.out) as out:
        (out / "fit.json").write_text(json.dumps(_clean(fit), indent=1))
        (out / "config.json").write_text(json.dumps(chosen, indent=2))
        (out / "config_tuned.json").write_text(json.dumps(fit["config"], indent=2))
        if "sweep" in fit:
            (out / "sweep.json").write_text(json.dumps(_clean(fit["sweep"]), indent=1))
        plots = [] if args.no_plots else plot_fits(fit, out)
        (out / "report.md").write_text(report_text(fit, plots, args))
    out = Path(args.out)
    print((out / "report.md").read_text())
    print("output folder: %s (fit.json, config.json, report.md%s)" % (out, ", plots" if plots else ""))
    return 0


def _distinct_logs(paths):
    """The log files once each: a file given twice (or a copy of one under another name) would be
    pooled with itself and claim twice the certainty. Says which were left out."""
    import hashlib

    seen, out = {}, []
    for p in paths:
        try:
            digest = hashlib.sha256(Path(p).read_bytes()).hexdigest()
        except OSError as e:
            raise UserError("cannot read %s: %s" % (p, e.strerror or e))
        if digest in seen:
            print("note: %s is the same log as %s: used once" % (p, seen[digest]))
            continue
        seen[digest] = p
        out.append(p)
    return out


def default_config(tuned):
    """The tuned configuration without its guidance keys: the measured boat (turning radius, RPM
    map) with the law's defaults, the other side of the sweep's comparison."""
    out = {k: dict(v) for k, v in tuned.items() if k != "guidance"}
    out["guidance"] = {"law": tuned.get("guidance", {}).get("law", "los")}
    return out


def _config_errors(partial):
    from trackpilot_tools.sim.runner import _fw_import

    _fw_import()
    from trackpilot import config as fwconfig

    return fwconfig.validate(partial)


def _pm(v, sd, fmt="%.3g"):
    if sd is None or not math.isfinite(sd):
        return (fmt % v) + " (uncertainty unknown)"
    return (fmt + " +- " + fmt) % (v, sd)


def _pooled_lines(pooled):
    """The report's account of pooled trials (tune_pool): what each gave, what was left out."""
    if not pooled:
        return []
    L = []
    for n, why in pooled.get("skipped", ()):
        L.append("Trial %d of the logs not used: %s.\n" % (n, why))
    if pooled["trials"] < 2:
        return L
    L.append("## %d trials pooled\n" % pooled["trials"])
    L.append("Each trial fitted alone, then weighted by its inverse variance; where the trials disagree "
             "beyond their uncertainties the pooled one is widened by the Birge ratio (below). The "
             "plots, the current and the compass offset are the last trial's.\n")
    L.append("| trial | start s | K' | T' | turning radius m | compass lag s | pilot gain | alone |")
    L.append("|---|---|---|---|---|---|---|---|")
    for t in pooled["per_trial"]:
        L.append("| %d | %.0f | %s | %s | %s | %s | %s | %s |" % (
            t["trial"], t["start_s"],
            _pm(t["k_prime"], t["k_prime_sd"]) if t["k_prime"] is not None else "no rudder report",
            _pm(t["t_prime"], t["t_prime_sd"]) if t["t_prime"] is not None else "no rudder report",
            _pm(t["radius_m"], t["radius_sd_m"], "%.2f"), _pm(t["compass_lag_s"], t["compass_lag_sd_s"], "%.2f"),
            ("%.2f" % t["pilot_gain"]) if t["pilot_gain"] > 0 else "not claimed",
            "; ".join(t["problems"]) if t["problems"] else "usable"))
    wide = ["%s x%.2f" % (k, b) for k, b in sorted(pooled["birge"].items()) if b > 1.0]
    L.append("\nBirge ratio (the pooled 1 sigma widened where the trials disagree): %s.\n" % (
        ", ".join(wide) if wide else "none needed"))
    return L


def report_text(fit, plots, args):
    n, c, ci, cur, sm, st, zz = (fit["nomoto"], fit["compass"], fit["circle"], fit["current"],
                                 fit["speed_map"], fit["steps"], fit["zigzag"])
    mg = fit["margins"]
    L = []
    L.append("# Commissioning trial: fit and tuned configuration\n")
    pooled = fit.get("pooled") or {}
    if pooled.get("trials", 1) > 1:
        L.append("Logs: %s  \nTrials: %d pooled (%s s). Uncertainties are 1 sigma.\n" % (
            ", ".join(args.logs), pooled["trials"], ", ".join("%.0f" % t["duration_s"] for t in pooled["per_trial"])))
    else:
        L.append("Logs: %s  \nTrial: %.0f s, %d manoeuvres. Uncertainties are 1 sigma.\n" % (
            ", ".join(args.logs), fit["trial"]["duration_s"], len(fit["trial"]["manoeuvres"])))
    if fit["problems"]:
        L.append("**TOO UNCERTAIN (written with --force):** " + "; ".join(fit["problems"]) + "\n")
    for d in fit.get("doubts", ()):
        L.append("**Less sure:** %s. The configuration does not take it: it is written. `sim --boat`, "
                 "`replay --closed-loop --boat` and `tune --sweep` sail a boat only this sure of it.\n" % d)
    for w in fit.get("warnings", ()):
        L.append("Note: %s.\n" % w)
    L.extend(_pooled_lines(fit.get("pooled")))
    if n is None:
        L.append("## Boat\n")
        L.append("| quantity | value |\n|---|---|")
        L.append("| K', T', the rudder's dead time | not identified: %s |" % fit["rudder"]["absent"])
    else:
        L.append("## Boat (Nomoto, L = %.1f m)\n" % n["length_m"])
        L.append("| quantity | value |\n|---|---|")
        L.append("| K' | %s |" % _pm(n["k_prime"], n["k_prime_sd"]))
        L.append("| T' | %s |" % _pm(n["t_prime"], n["t_prime_sd"]))
        if "t_prime_sd_fit" in n:
            # the fit's own (the heading's noise) and the current's part (measured from the trial)
            L.append("| ... of which the heading's noise / the current (its walk, the circles' error) | "
                     "K' +- %.3g / +- %.3g, T' +- %.3g / +- %.3g; the current walked about %.3f m/s per "
                     "minute (sqrt of its variance rate) |" % (
                         n["k_prime_sd_fit"], n["k_prime_sd_current"], n["t_prime_sd_fit"],
                         n["t_prime_sd_current"], math.sqrt(60.0 * fit["current_drift"]["q_mps2_per_s"])))
        if "dead_time_s" in n:
            L.append("| dead time, rudder report -> heading (the flow lag, the GNSS latency's error and the "
                     "report timing together: the flow lag itself is not identified) | %s s |" % _pm(
                         n["dead_time_s"], n["dead_time_sd_s"], "%.2f"))
        else:
            L.append("| rudder flow lag | %s s |" % _pm(n["rudder_lag_s"], n["rudder_lag_sd_s"], "%.2f"))
        L.append("| wind's yaw moment modelled from | %s |" % (
            "the wind sensor's apparent wind" if n.get("wind_model") == "sensor"
            else "the heading (a constant wind: no wind sensor in the log)"))
        L.append("| heading fit RMS | %.2f deg over %d windows of 20 s (zig-zag and circles) |" % (
            n["rms_deg"], n["windows"]))
    L.append("| turning radius (circles, %s) | %s m |" % (
        "full rudder" if n is None else "%.0f deg rudder" % ci["rudder_deg"], _pm(ci["radius_m"], ci["radius_sd_m"], "%.2f")))
    if n is not None:
        L.append("| ... from K' at that rudder (check) | %.2f m |" % ci["radius_from_k_prime_m"])
    L.append("| current seen | %.2f m/s towards %.0f deg (+- %.2f) |" % (cur["speed_mps"], cur["to_deg"], cur["sd_mps"]))
    if len(cur.get("by_time", ())) > 1:
        # each group of circles' own current; the water speed takes it in time between them
        L.append("| ... by circle group (trial time) | %s |" % ", ".join(
            "%.0f s: %.2f m/s towards %.0f deg (+- %.2f)" % (
                b["t_s"] - fit["trial"]["start_s"], math.hypot(b["east_mps"], b["north_mps"]),
                math.degrees(math.atan2(b["east_mps"], b["north_mps"])) % 360.0, b["sd_mps"])
            for b in cur["by_time"]))
    if "leeway_per_crosswind" in cur:
        L.append("| leeway (sideways drift per m/s of apparent crosswind, from the circles) | %.3f |"
                 % abs(cur["leeway_per_crosswind"]))
    elif cur.get("leeway_model") == "heading":
        L.append("| leeway | modelled as a constant wind's (no wind sensor in the log) |")
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
            rpm, s["steps"], ("".join((
                (" (%d not settled)" % s["unsettled"]) if s["unsettled"] else "",
                (" (%d left out: the pilot was off its course as the key came)" % s["off_course"])
                if s.get("off_course") and not s.get("all_off_course") else ""))),
            _pm(s["delay_s"], s["delay_s_sd"], "%.2f"), _pm(s["tc_s"], s["tc_s_sd"], "%.2f"),
            _pm(100 * s["overshoot"], 100 * s["overshoot_sd"] if math.isfinite(s["overshoot_sd"]) else None, "%.0f"),
            _pm(s["gain"], s["gain_sd"], "%.2f"), _pm(s["steady_err_deg"], s["steady_err_deg_sd"], "%.1f")))
    L.append("\nTimes from the keystroke; levels of the step the pilot was asked to make (the key plus "
             "its standing error as the key came); the delay, time constant and overshoot from a "
             "second-order lag with dead time fitted to each step (steps.png, dashed), the gain from "
             "its last 3 s. Each value is the median over the steps used, +- its 1 sigma (1.25 x the "
             "standard error a mean would have).")
    pg = fit.get("pilot_gain") or {}
    if pg.get("gain", 0.0) > 0.0:
        L.append("\nThe pilot's own loop (P-D models run between its reports, tune_fit.fit_pilot_gain): "
                 "rudder gain %s deg per deg of course error, damping %s s (deg of rudder per deg/s of "
                 "compass rate; on simulated trials within 15 %% on half, biased low), ram %.1f deg/s; "
                 "deadband %s deg (roughly: within 0.5 deg on 25 of 40 simulated trials); "
                 "%d reports, %.1f deg RMS. `sim --boat` sails them; the "
                 "gain is not written into the configuration: the law learns the gain on the water and "
                 "clips a high one itself. guidance.los_pilot_gain would clip from the first engage: on "
                 "simulated boats fewer runs swing, but pilots that hunt on their own sail worse, and "
                 "the trial does not tell them apart (docs/COMMISSIONING.md); set it where the pilot "
                 "does not hunt." % (
                     _pm(pg["gain"], pg["gain_sd"], "%.2f"), _pm(pg["damping_s"], pg["damping_sd_s"], "%.2f"),
                     pg["ram_dps"], _pm(pg["deadband_deg"], pg["deadband_sd_deg"], "%.1f"), pg["scored"],
                     pg["rms_deg"]))
        if not fit.get("limit_cycles"):
            from trackpilot_tools import tune_fit as F

            L.append("\nSimulated alone on the fitted boat in quiet water, the pilot as fitted comes out "
                     "of a %.0f deg course change at %s m/s (no limit cycle; tune_fit.pilot_limit_cycles)." % (
                         F.LIMIT_CYCLE_STEP_DEG, ", ".join("%g" % u for u in F.LIMIT_CYCLE_SPEEDS_MPS)))
    elif pg:
        L.append("\nThe pilot's own rudder gain: not identified from this trial (%s)." % pg.get("why", "?"))
    for rpm, peaks in sorted(zz["overshoot_deg"].items()):
        L.append("\nZig-zag at %d RPM, overshoot: %s deg (mean %.1f)." % (
            rpm, ", ".join("%.1f" % x for x in peaks), zz["mean_overshoot_deg"][rpm]))
    L.append("")
    L.append("## Tuned configuration (config_tuned.json)\n")
    L.append("```json\n%s\n```\n" % json.dumps(fit["config"], indent=2))
    L.append("Margins: the closed heading response at %d RPM (the slowest) reaches 63 %% of a course "
             "step %.2f +- %.2f s after the key (tau). The lookahead and the lead stay the law's "
             "defaults (T_la = %.1f s, T_d = %.1f s from 2 m/s up, longer on slower legs; the swing "
             "watch adapts them on line): damping "
             "ratio of the xte loop zeta = 0.5 (1 + T_d / T_la) sqrt(T_la / tau) = %.2f at tau, %.2f "
             "at tau + 2 sigma = %.2f s; zeta stays >= 0.5 up to tau = %.1f s (the zeta rule would "
             "ask T_la = %.1f s; measured worse than the defaults, not used). The ALOS gain "
             "los_alos_gain = %.5f: the default x min(1, (%.1f s / tau)^2) = x%.2f (its integrator "
             "and a slow heading response swing together, docs/COMMISSIONING.md). Phase margin of "
             "the loop without the lead, with the measured delay: %.0f deg." % (
                 mg["at_rpm"], mg["tau_s"], mg["tau_sd_s"], mg["t_la_s"], mg["t_d_s"], mg["zeta_at_tau"],
                 mg["zeta_at_design"], mg["tau_design_s"], mg["tau_for_zeta_0p5_s"], mg["t_la_zeta_rule_s"],
                 fit["config"]["guidance"]["los_alos_gain"], mg["tau_ref_s"], mg["alos_scale"],
                 mg["phase_margin_no_lead_deg"]))
    L.append("The turning radius in the configuration is the measured one plus 2 sigma.\n")
    L.append("## Sweep around the fitted point and recommendation\n")
    if "sweep" in fit:
        from trackpilot_tools import tune_sweep as S

        L.append("%d boats drawn around the fit within its 1-sigma uncertainty (the pilot's gain, "
                 "damping and deadband around their fits, its ram as measured; key delay, wind, waves "
                 "and GNSS latency from the robust bench's spreads: the trial does not identify "
                 "them), one straight each at 1, 2 or "
                 "3 m/s, law `los`, truth xte:\n" % fit["sweep"]["boats"])
        L.append(S.table_md(fit["sweep"]["summary"]) + "\n")
    else:
        L.append("Not run. `trackpilot tune LOG --sweep 20` sails 20 boats around the fit with the "
                 "tuned and the default guidance (Dask, `--jobs`/`--scheduler`) and recommends one.\n")
    L.append("**Recommended: %s** (%s). config.json holds it%s.\n" % (
        fit["recommended"][0], fit["recommended"][1],
        "" if fit["recommended"][0] == "tuned" else ": the measured boat's radius and RPM map with the law's default guidance"))
    if fit["sim_params"] is not None:
        L.append("Predicted accuracy on the fitted boat: `trackpilot sim TRACK --boat fit.json "
                 "--fw-config config.json`; on a logged run: `trackpilot replay LOG --closed-loop "
                 "--boat fit.json --law los --fw-config config.json`.\n")
    L.append("Install: `trackpilot upload --config config.json` (STANDBY only; validated on the board).\n")
    if plots:
        L.append("## Plots\n")
        for p in plots:
            L.append("- %s" % p)
    return "\n".join(L) + "\n"


_STEP_COLOURS = ("C0", "C1", "C2", "C3", "C4", "C5", "C6", "C8", "C9")  # not C7: grey is "left out"


def plot_fits(fit, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = []
    # Nomoto: the windows' measured heading against the model
    if fit["nomoto"] is not None:  # not identified without a rudder report
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
    # steps: each step's heading (solid) and the model fitted to it (dashed); grey: left out, the
    # pilot was off its course as the key came
    from trackpilot_tools.tune_fit import second_order_step

    curves = fit["steps"]["_plot"]
    recs = fit["steps"].get("records") or []
    if len(recs) != len(curves):
        recs = [{}] * len(curves)  # a pooled fit: the curves of its last trial, no models
    rpms = sorted({c[0] for c in curves})
    fig, axes = plt.subplots(1, max(1, len(rpms)), figsize=(5 * max(1, len(rpms)), 4), squeeze=False)
    for k, rpm_k in enumerate(rpms):
        ax = axes[0][k]
        for i, ((rpm, dlt, ts, y), rec) in enumerate(zip(curves, recs)):
            if rpm != rpm_k:
                continue
            clean = rec.get("clean", True)
            col = _STEP_COLOURS[i % len(_STEP_COLOURS)] if clean else "0.7"
            label = "%+.0f deg" % dlt if clean else "%+.0f deg (left out)" % dlt
            ax.plot(ts, y, "-", color=col, lw=1, label=label)
            mod = rec.get("model")
            if mod:
                tf = np.linspace(0.0, float(ts[-1]) if len(ts) else 10.0, 200)
                ax.plot(tf, mod["gain"] * second_order_step(tf - mod["delay_s"], mod["wn_rad_s"], mod["zeta"]),
                        "--", color=col, lw=1)
        ax.axhline(1.0, color="k", lw=0.5)
        ax.axhline(0.63, color="k", lw=0.3, ls=":")
        ax.set_xlabel("time after the key (s)")
        ax.set_ylabel("heading change / step")
        ax.legend(fontsize=7)
        ax.set_title("%d RPM (solid: heading, dashed: model)" % rpm_k)
    fig.suptitle("Closed heading response to course steps")
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
