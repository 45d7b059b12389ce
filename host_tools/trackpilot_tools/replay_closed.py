"""`trackpilot replay LOG --closed-loop --law B`: re-sail a logged run in the simulator.

The logged run's track (its track record), its state when AUTO began (position, heading, speed over
ground as the water speed) and the current it met (the mean of ground velocity minus water velocity
along the heading over the AUTO span, the water speed from the boat's RPM -> speed map) are given to
the simulated boat: the boat `trackpilot tune` identified (--boat FIT.json) or the nominal one. The
firmware then sails it with law/configuration B (--law, --config, --set). Both runs are judged the
same way: the firmware's own logged xte against the distance along the track, RMS and max |xte| and
the keystrokes, over the part of the track the logged run sailed in AUTO.

Not reproduced: wind and waves (the calm preset; the log does not tell them apart from the
boat), the pilot's own gains (the simulator's defaults: the trial measures the closed response,
not the ST2000+'s settings), and the time before AUTO (the re-sail starts at AUTO's state and
engages as soon as the simulated GNSS is fixed, about 3 s).
"""
import csv
import json
import math
from pathlib import Path

import numpy as np

from trackpilot_tools.errors import UserError

D2R = math.pi / 180.0


def auto_span(d):
    """(first, last) index of the first AUTO span of the decoded log's control records; UserError
    without one or without a track."""
    from trackpilot_tools.logdecode import mode_name

    if d.track is None or not getattr(d.track, "waypoints", None):
        raise UserError("cannot re-sail: the log has no track record (the firmware logs the track "
                        "when one is loaded; a log from before loading a track has none)")
    i0 = None
    for i, r in enumerate(d.controls):
        if mode_name(r.mode).startswith("AUTO") and r.pos_valid and r.heading_valid:
            if i0 is None:
                i0 = i
        elif i0 is not None:
            return i0, i - 1
    if i0 is None:
        raise UserError("cannot re-sail: the log never was in AUTO with a valid position and heading "
                        "(there is no logged run to compare with)")
    return i0, len(d.controls) - 1


def write_track(d, path):
    """The logged track record as a track CSV the firmware and the simulator read."""
    with open(path, "w", newline="") as f:
        f.write("lon,lat,speed_mps,name,radius_m\n")
        for w in d.track.waypoints:
            lat, lon = w.lat_e7 * 1e-7, w.lon_e7 * 1e-7
            rad = "" if getattr(w, "radius_m", None) is None else "%.1f" % w.radius_m
            name = (getattr(w, "name", "") or "").replace(",", " ")
            f.write("%.7f,%.7f,%.2f,%s,%s\n" % (lon, lat, w.speed_mps, name, rad))
    return path


def _latlon(r):
    return (r.lat_e7 * 100 + r.lat_hp) * 1e-9, (r.lon_e7 * 100 + r.lon_hp) * 1e-9


def measured_current(recs, boat):
    """Current (east, north m/s) from the log: ground velocity minus the water velocity along the
    heading, the water speed from the boat's RPM map, over records at a steady RPM."""
    from trackpilot_tools.sim.boat import interp_map

    rows = []
    for r in recs:
        if not (r.vel_valid and r.heading_valid) or r.rpm <= 0 or abs(r.rpm - r.rpm_set) > 30:
            continue
        u = interp_map(boat["rpm_speed_map"], r.rpm) * boat.get("speed_map_scale", 1.0)
        h = r.heading_deg * D2R
        rows.append((r.sog_mps * math.sin(r.cog_deg * D2R) - u * math.sin(h),
                     r.sog_mps * math.cos(r.cog_deg * D2R) - u * math.cos(h)))
    if len(rows) < 20:
        return 0.0, 0.0, 0
    a = np.array(rows)
    return float(np.median(a[:, 0])), float(np.median(a[:, 1])), len(rows)


def judge(recs, geom):
    """[(along-track m, xte m, east, north)] of AUTO records and (rms, max |xte|, keystrokes)."""
    pts = []
    keys = 0
    prev = None
    for r in recs:
        if prev is not None and r.keys_sent >= prev.keys_sent:
            keys += r.keys_sent - prev.keys_sent
        prev = r
        if not r.pos_valid:
            continue
        e, n = geom_frame_xy(geom, r)
        _leg, _x, along = geom.update(e, n)
        pts.append((along, r.xte_m, e, n))
    return pts, keys


def geom_frame_xy(geom, r):
    lat, lon = _latlon(r)
    return geom.frame.from_latlon(lat, lon)


def stats(pts, upto_m=None):
    x = [p[1] for p in pts if upto_m is None or p[0] <= upto_m]
    if not x:
        return None, None
    return math.sqrt(sum(v * v for v in x) / len(x)), max(abs(v) for v in x)


def auto_records(d):
    i0, i1 = auto_span(d)
    return d.controls[i0:i1 + 1]


def resail(logs, out, law=None, config=None, sets=(), boat_fit=None, seed=1):
    """Re-sail; returns a dict with both runs' figures and the files written in `out`."""
    from trackpilot_tools import logdecode
    from trackpilot_tools.sim import params as P
    from trackpilot_tools.sim import scenarios
    from trackpilot_tools.sim.geodesy import LocalFrame
    from trackpilot_tools.sim.runner import SimRun
    from trackpilot_tools.sim.truth import TrackGeom

    try:
        d = logdecode.decode_files(logs)
    except logdecode.LogError as e:
        raise UserError(str(e))
    recs = auto_records(d)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    track = write_track(d, out / "track.csv")
    p = P.load()
    P.merge(p, scenarios.PRESETS["calm"])
    boat_name = "nominal"
    if boat_fit:
        from trackpilot_tools.sim_cmd import boat_overrides

        try:
            P.merge(p, boat_overrides(boat_fit))
        except (OSError, ValueError) as e:
            raise UserError(str(e))
        boat_name = str(boat_fit)
    ce, cn, n_cur = measured_current(recs, p["boat"])
    p["water"]["current_mps"] = math.hypot(ce, cn)
    p["water"]["current_dir_deg"] = math.degrees(math.atan2(ce, cn)) % 360.0
    p["water"]["current_walk_sd_mps"] = 0.0
    r0 = recs[0]
    lat0, lon0 = _latlon(r0)
    start = {"lat_deg": lat0, "lon_deg": lon0, "heading_deg": r0.heading_deg,
             "u_mps": r0.sog_mps if r0.vel_valid else 0.0}
    fw = {}
    if config:
        try:
            fw = json.loads(Path(config).read_text())
        except (OSError, ValueError) as e:
            raise UserError("--config %s: %s" % (config, e))
    for sec, body in P.parse_set(sets or ()).items():  # checked by replay_cmd._check_sets
        fw.setdefault(sec, {}).update(body)
    if law:
        fw.setdefault("guidance", {})["law"] = law
    run = SimRun(track, out / "resail", seed=seed, law=fw.get("guidance", {}).get("law", "los"), params=p,
                 fw_config=fw, start_state=start)
    res = run.run()
    dr = logdecode.decode_files(sorted((out / "resail" / "fw" / "log").glob("*.tpl")))
    try:
        recs_b = auto_records(dr)
    except UserError:
        raise UserError("the re-sailed run never reached AUTO (%s): see %s" % (res.get("stop_reason"), out / "resail"))
    wps = [_latlon_w(w) for w in d.track.waypoints]
    frame = LocalFrame(*wps[0])
    pts_a, keys_a = judge(recs, _geom(TrackGeom, frame, wps))
    pts_b, keys_b = judge(recs_b, _geom(TrackGeom, frame, wps))
    upto = max(p_[0] for p_ in pts_a) if pts_a else None
    ra, ma = stats(pts_a)
    rb, mb = stats(pts_b, upto)
    km_a = max(upto - min(p_[0] for p_ in pts_a), 1.0) / 1000.0 if pts_a else None
    keys_b_upto = _keys_upto(recs_b, pts_b, upto)
    result = {"logged": {"rms_m": ra, "max_m": ma, "keys": keys_a, "records": len(recs)},
              "resailed": {"rms_m": rb, "max_m": mb, "keys": keys_b_upto, "records": len(recs_b),
                           "law": run.law, "stop": res.get("stop_reason")},
              "along_track_m": upto, "km": km_a, "boat": boat_name,
              "current": {"east_mps": ce, "north_mps": cn, "records": n_cur},
              "start": start, "fw_config": fw}
    (out / "replay_closed.json").write_text(json.dumps(result, indent=1))
    with open(out / "xte.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "along_track_m", "xte_m", "east_m", "north_m"])
        for name, pts in (("logged", pts_a), ("resailed", pts_b)):
            for a, x, e, n in pts:
                w.writerow([name, "%.2f" % a, "%.3f" % x, "%.2f" % e, "%.2f" % n])
    result["_pts"] = (pts_a, pts_b, [frame.from_latlon(*w) for w in wps])
    return result


def _latlon_w(w):
    return w.lat_e7 * 1e-7, w.lon_e7 * 1e-7


def _geom(cls, frame, wps):
    g = cls(frame, wps)
    g.frame = frame
    return g


def _keys_upto(recs, pts, upto):
    """Keystrokes of the re-sail up to the along-track distance the logged run reached."""
    keys = 0
    prev = None
    along = iter(pts)
    cur = None
    for r in recs:
        if r.pos_valid:
            cur = next(along, cur)
        if cur is not None and upto is not None and cur[0] > upto:
            break
        if prev is not None and r.keys_sent >= prev.keys_sent:
            keys += r.keys_sent - prev.keys_sent
        prev = r
    return keys


def plot(result, path, law_a, law_b):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts_a, pts_b, wxy = result["_pts"]
    fig, ax = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [3, 2]})
    for pts, lab in ((pts_a, "logged (%s)" % law_a), (pts_b, "re-sailed (%s)" % law_b)):
        ax[0].plot([p[0] for p in pts], [p[1] for p in pts], lw=1, label=lab)
        ax[1].plot([p[2] for p in pts], [p[3] for p in pts], lw=1, label=lab)
    ax[0].axhline(0, color="k", lw=0.5)
    ax[0].set_xlabel("distance along the track (m)")
    ax[0].set_ylabel("xte (m, + stbd, firmware's)")
    ax[0].legend(fontsize=8)
    ax[0].grid(True, alpha=0.3)
    ax[1].plot([w[0] for w in wxy], [w[1] for w in wxy], "k--", lw=0.8, label="track")
    ax[1].set_aspect("equal", adjustable="datalim")
    ax[1].set_xlabel("east (m)")
    ax[1].set_ylabel("north (m)")
    ax[1].legend(fontsize=8)
    ax[1].grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def cmd(args, logs):
    if args.journal:
        raise UserError("--closed-loop and --journal are two different replays: give one")
    from trackpilot_tools import logdecode
    from trackpilot_tools.outdir import fresh_output

    try:  # a log that cannot be re-sailed is refused before anything is written
        auto_records(logdecode.decode_files(logs))
    except logdecode.LogError as e:
        raise UserError(str(e))
    if args.boat:
        from trackpilot_tools.sim_cmd import boat_overrides, say_boat_doubts

        try:
            boat_overrides(args.boat)
        except ValueError as e:
            raise UserError(str(e))
        say_boat_doubts(args.boat)
    final = Path(args.out or "replay_closed_out")
    with fresh_output(final) as out:
        res = resail(logs, out, args.law, args.config, args.set or (), args.boat)
        law_a, law_b = "as logged", res["resailed"]["law"]
        if not args.no_plot:
            plot(res, out / "replay_closed.png", law_a, law_b)
    out = final
    a, b = res["logged"], res["resailed"]
    print("re-sailed %.0f m of track on the %s boat, current %.2f m/s towards %.0f deg (from the log), "
          "law %s" % (res["along_track_m"] or 0, "fitted" if args.boat else "nominal",
                      math.hypot(res["current"]["east_mps"], res["current"]["north_mps"]),
                      math.degrees(math.atan2(res["current"]["east_mps"], res["current"]["north_mps"])) % 360, law_b))
    for name, r, law in (("logged   ", a, law_a), ("re-sailed", b, law_b)):
        if r["rms_m"] is None:
            print("%s (%s): no AUTO records" % (name, law))
        else:
            print("%s (%s): RMS |xte| %.2f m, max %.2f m, keystrokes %d" % (name, law, r["rms_m"], r["max_m"], r["keys"]))
    print("output folder: %s (replay_closed.json, xte.csv%s, resail/: the re-sailed run)" % (
        out, "" if args.no_plot else ", replay_closed.png"))
    return 0
