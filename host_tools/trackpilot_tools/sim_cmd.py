"""`trackpilot sim TRACK`: sail a track with the real firmware (MicroPython unix port) against the
simulated boat, and write an output folder: the firmware's log, truth.csv, summary.json/.md, plots."""
import json
import os
import sys
from pathlib import Path

from .errors import UserError
from .outdir import fresh_output


def add_parser(p):
    from .sim import scenarios

    p.add_argument("track", help="track CSV (tracks/README.md)")
    p.add_argument("--law", choices=("seed", "los"), default="los", help="guidance law (default los)")
    p.add_argument("--scenario", default="calm", choices=sorted(scenarios.PRESETS),
                   help="environment preset (default calm)")
    p.add_argument("--current-mps", type=float, help="constant current speed")
    p.add_argument("--current-dir-deg", type=float, help="direction the current flows TO (true)")
    p.add_argument("--wind-mps", type=float, help="mean wind speed")
    p.add_argument("--wind-dir-deg", type=float, help="direction the wind blows FROM (true)")
    p.add_argument("--gust-frac", type=float, help="gust s.d. as a fraction of the mean wind")
    p.add_argument("--wave-yaw-deg", type=float, help="wave yaw RMS (deg)")
    p.add_argument("--fault", action="append", default=[], metavar="NAME@T[:D]",
                   help="inject a fault at T s for D s; names: " + ", ".join(sorted(scenarios.FAULTS)))
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", default="sim_out", help="output folder (default sim_out)")
    p.add_argument("--realtime", action="store_true", help="pace the run to the wall clock")
    p.add_argument("--realtime-speed", type=float, default=1.0, help="with --realtime: x real time")
    p.add_argument("--udp-out", action="store_true",
                   help="send the firmware's status datagrams to UDP-HOST:10111 (trackpilot monitor) "
                        "and its NMEA to UDP-HOST:10110 (OpenCPN); default with --realtime")
    p.add_argument("--udp-host", default="127.0.0.1",
                   help="with --udp-out: where to send, a host, an address or a broadcast address such "
                        "as 192.168.1.255 (default 127.0.0.1)")
    p.add_argument("--udp-port", type=int, default=10111, help="status datagram port (default 10111)")
    p.add_argument("--nmea-port", type=int, default=10110, help="NMEA 0183 port (default 10110)")
    p.add_argument("--duration-s", type=float, help="time limit (default 1.5 x the track's time + 120 s)")
    p.add_argument("--params", help="JSON file merged over the simulator's boat_params.json")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override one simulator parameter, e.g. pilot.deadband_deg=3")
    p.add_argument("--fw-config", metavar="FILE",
                   help="the firmware's config.json as-is, not checked here (to see how the firmware "
                        "treats a bad file); replaces --fw-set")
    p.add_argument("--fw-set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override one firmware configuration setting, e.g. guidance.seed_k_y_deg_per_m=2")
    p.add_argument("--start-offset-m", type=float, help="start this far to starboard of the first leg")
    p.add_argument("--reengage-s", type=float, default=0.0,
                   help="press ENGAGE again this long after the firmware leaves AUTO (0: never)")
    p.add_argument("--journal", action="store_true",
                   help="the firmware writes every input of its decision core to OUT/fw/journal.txt "
                        "(check with: trackpilot replay OUT/fw/log/*.tpl --config OUT/config.json --journal OUT/fw/journal.txt)")
    p.add_argument("--trial", action="store_true",
                   help="press TRIAL instead of ENGAGE: sail the commissioning trial (docs/COMMISSIONING.md)")
    p.add_argument("--boat", metavar="FIT.json",
                   help="sail the boat identified by `trackpilot tune` (its sim_params over the defaults)")
    p.add_argument("--no-plots", action="store_true")
    p.add_argument("--verbose", action="store_true", help="firmware diagnostics into firmware_stderr.txt")
    p.set_defaults(func=run)


def build_overrides(args):
    from .sim import params as pm

    over = {}
    if getattr(args, "boat", None):
        over = boat_overrides(args.boat)
    pm.merge_new(over, pm.parse_set(args.set))

    def put(sec, key, val):
        if val is not None:
            over.setdefault(sec, {})[key] = val
    put("water", "current_mps", args.current_mps)
    put("water", "current_dir_deg", args.current_dir_deg)
    put("wind", "speed_mps", args.wind_mps)
    put("wind", "dir_deg", args.wind_dir_deg)
    put("wind", "gust_sd_frac", args.gust_frac)
    put("water", "wave_yaw_rms_deg", args.wave_yaw_deg)
    put("sim", "start_offset_m", args.start_offset_m)
    return over


# the environment's options and their `--set` keys: a physical range (an absurd value broke the
# run with a traceback deep in the simulator, e.g. --current-mps 1e9 in the GNSS encoder)
_RANGES = {
    ("water", "current_mps"): (0.0, 3.0, "--current-mps / water.current_mps"),
    ("wind", "speed_mps"): (0.0, 40.0, "--wind-mps / wind.speed_mps"),
    ("wind", "gust_sd_frac"): (0.0, 2.0, "--gust-frac / wind.gust_sd_frac"),
    ("water", "wave_yaw_rms_deg"): (0.0, 30.0, "--wave-yaw-deg / water.wave_yaw_rms_deg"),
    ("sim", "start_offset_m"): (-1000.0, 1000.0, "--start-offset-m / sim.start_offset_m"),
}


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _override_problem(over, base, path=()):
    """One line naming the first simulator override whose value cannot be sailed (a number where
    the parameter is a number, finite, within _RANGES), else None."""
    import math

    for key, v in over.items():
        where = path + (key,)
        d = base.get(key) if isinstance(base, dict) else None
        if isinstance(v, dict):
            p = _override_problem(v, d if isinstance(d, dict) else {}, where)
            if p:
                return p
            continue
        name = ".".join(where)
        if _is_number(d) or where in _RANGES:
            if not _is_number(v) or not math.isfinite(v):
                return "%s=%s: a finite number is needed" % (name, _json_text(v))
            lim = _RANGES.get(where)
            if lim and not lim[0] <= v <= lim[1]:
                return "%s %s: outside %g..%g" % (lim[2], _json_text(v), lim[0], lim[1])
        elif isinstance(d, list) and d and all(_is_number(x) for x in d):
            if not isinstance(v, list) or not all(_is_number(x) and math.isfinite(x) for x in v):
                return "%s=%s: a list of finite numbers is needed, like %s" % (name, _json_text(v), _json_text(d))
    return None


def _json_text(v):
    import json

    try:
        return json.dumps(v)
    except (TypeError, ValueError):
        return repr(v)


def boat_overrides(path):
    """The simulator parameters of a boat fitted by `trackpilot tune` (FIT.json's sim_params).
    ValueError with one line when the file is not such a fit."""
    return _read_boat_fit(path)["sim_params"]


def say_boat_doubts(path):
    """Once per command: tune's doubts about the simulated boat in FIT.json (fits only that boat
    takes, beyond their limit), on stderr, each with the manoeuvre to sail again."""
    for d in _read_boat_fit(path).get("doubts") or ():
        print("note: --boat %s: %s" % (path, d), file=sys.stderr)


def _read_boat_fit(path):
    import json

    try:
        fit = json.loads(Path(path).read_text())
    except OSError as e:
        raise ValueError("--boat %s: cannot read it (%s)" % (path, e.strerror or e))
    except ValueError:
        raise ValueError("--boat %s: not JSON (write one with `trackpilot tune LOG`)" % path)
    if isinstance(fit, dict) and "sim_params" in fit and fit["sim_params"] is None:
        why = (fit.get("rudder") or {}).get("absent") or "K' and T' were not identified"
        raise ValueError("--boat %s: this fit cannot be sailed: %s, so the boat's K' and T' are not "
                         "known (docs/COMMISSIONING.md)" % (path, why))
    if not isinstance(fit, dict) or not isinstance(fit.get("sim_params"), dict):
        raise ValueError("--boat %s: no sim_params in it (write one with `trackpilot tune LOG`)" % path)
    return fit


def check_inputs(args):
    """Every input checked before the run starts: (simulator overrides, firmware settings).
    Raises UserError with one line naming the mistake."""
    from .sim import params as pm
    from .sim import scenarios
    from .sim.runner import _fw_import

    _fw_import()
    from trackpilot import config as fwconfig
    from trackpilot.nav.track import TrackError, parse_track_csv

    track = Path(args.track)
    if not track.is_file():
        raise UserError("no such track file: %s" % track)
    try:
        parse_track_csv(track.read_bytes())
    except TrackError as e:
        raise UserError("%s: %s (check it with `trackpilot track check %s`)" % (track, e, track))
    for f in args.fault:
        try:
            scenarios.parse_fault(f)
        except ValueError as e:
            raise UserError(str(e))
    try:
        over = build_overrides(args)
        fw_set = pm.parse_set(args.fw_set)
    except ValueError as e:
        raise UserError(str(e))
    if args.params and not Path(args.params).is_file():
        raise UserError("no such parameter file: %s" % args.params)
    try:
        p = pm.load(args.params, over)
        pm.merge(p, scenarios.PRESETS[args.scenario])
    except KeyError as e:
        raise UserError(e.args[0] + " (the names are in sim/boat_params.json)")
    except ValueError as e:  # a parameter file that is not JSON
        raise UserError("%s: not a JSON parameter file (%s)" % (args.params, e))
    problem = _override_problem(over, pm.load(args.params))
    if problem:
        raise UserError(problem)
    errors = fwconfig.validate(fw_set)
    if errors:
        raise UserError("--fw-set: " + "; ".join(errors))
    if args.reengage_s is not None and not 0.0 <= args.reengage_s < 1e6:
        raise UserError("--reengage-s must be seconds >= 0")
    for name in ("duration_s", "realtime_speed"):
        v = getattr(args, name)
        if v is not None and not v > 0:
            raise UserError("--%s must be > 0" % name.replace("_", "-"))
    for name in ("udp_port", "nmea_port"):
        if not 0 < getattr(args, name) < 65536:
            raise UserError("--%s must be a UDP port, 1..65535" % name.replace("_", "-"))
    if args.fw_config and not Path(args.fw_config).is_file():
        raise UserError("no such firmware config file: %s" % args.fw_config)
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise UserError("--out %s is a file, not a folder" % args.out)
    return over, fw_set


def udp_targets(args):
    """(host, status port, NMEA port) for the live datagrams, or None."""
    if not (args.udp_out or args.realtime):
        return None
    return (args.udp_host, args.udp_port, args.nmea_port)


def run(args):
    check_inputs(args)
    if getattr(args, "boat", None):
        say_boat_doubts(args.boat)  # readable: check_inputs loaded it
    final = Path(args.out)
    try:
        with fresh_output(final) as out:
            res, summ, plots = _sail(args, out)
    except KeyboardInterrupt:
        print("\ninterrupted: the partial output is in %s.partial/ (see PARTIAL.txt there); "
              "%s/ is unchanged" % (final, final), file=sys.stderr)
        raise
    out = final
    print((out / "summary.md").read_text())
    print("output folder: %s" % out)
    print("  firmware log: %s" % ", ".join(str(out / f) for f in summ["firmware_log_files"])
          if summ["firmware_log_files"]
          else "  firmware log: none written")
    print("  truth trace:  %s" % (out / "truth.csv"))
    print("  summary:      %s, %s" % (out / "summary.json", out / "summary.md"))
    for p in plots:
        print("  plot:         %s" % (out / p))
    return 0 if res["failure"] is None else 1


def _sail(args, out):
    """The run itself, writing into `out` (the fresh temporary folder)."""
    from .sim import params as pm
    from .sim import report
    from .sim.runner import SimRun

    fw_bytes = Path(args.fw_config).read_bytes() if args.fw_config else None  # readable: check_inputs
    run_ = SimRun(args.track, out, seed=args.seed, law=args.law, scenario=args.scenario,
                  faults=args.fault, param_file=args.params, overrides=build_overrides(args),
                  duration_s=args.duration_s, realtime=args.realtime,
                  realtime_speed=args.realtime_speed,
                  udp_out=udp_targets(args),
                  fw_config=pm.parse_set(args.fw_set),
                  fw_config_bytes=fw_bytes,
                  reengage_s=args.reengage_s, quiet=not args.verbose, trial=args.trial,
                  journal=args.journal)
    res = run_.run()
    meta = {"track": str(args.track), "law": args.law, "scenario": args.scenario, "seed": args.seed,
            "faults": args.fault}
    summ = report.summarize_run(res, meta)
    report.write_summary(summ, out)
    plots = []
    if not args.no_plots:
        plots = report.plot_truth(str(out), res["geom"]) + report.plot_firmware_log(str(out))
    return res, summ, [os.path.relpath(p, out) for p in plots]
