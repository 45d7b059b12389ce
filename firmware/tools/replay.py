"""Replay a trackpilot log through the firmware's own navigation and guidance (host tool).

    micropython firmware/tools/replay.py LOG.tpl [LOG2.tpl ...] [--config CFG.json]
        [--law seed|los] [--set guidance.KEY=VALUE ...] [--csv]

For every control record of the log it rebuilds the GNSS fix the boat used (the log holds it at
exactly the resolution the app steered with), runs the same `control.guide_epoch` as the app with
the same progress and guidance law, and compares the heading and speed commands with the logged
ones. With the configuration the boat ran, the commands agree bit for bit (at the log's
resolution); with another law or other parameters it shows what they would have commanded for the
same inputs (open loop: the boat's motion is the logged one).

Output (stdout): with --csv one line per guided record `t_ms,leg,logged_cmd,replayed_cmd,...`,
then `SUMMARY key=value ...`.
"""
import json
import sys

from trackpilot import config, control, guidance, logfmt, progress
from trackpilot.fix import Fix
from trackpilot.track import from_waypoints

_RTK = {"single": 1, "float": 2, "fixed": 3}


def _args(argv):
    logs, cfg_path, law, sets, csv = [], None, None, [], False
    i = 1
    while i < len(argv):
        a = argv[i]
        if a == "--config":
            cfg_path = argv[i + 1]
            i += 2
        elif a == "--law":
            law = argv[i + 1]
            i += 2
        elif a == "--set":
            sets.append(argv[i + 1])
            i += 2
        elif a == "--csv":
            csv = True
            i += 1
        else:
            logs.append(a)
            i += 1
    return logs, cfg_path, law, sets, csv


def _apply_sets(cfg, sets):
    for item in sets:
        key, _, value = item.partition("=")
        sec, _, name = key.partition(".")
        try:
            v = json.loads(value)
        except ValueError:
            v = value
        cfg.setdefault(sec, {})[name] = v
    errors = config.validate(cfg)
    if errors:
        raise SystemExit("replay: bad setting: " + "; ".join(errors))
    return cfg


def _fill(fix, r):
    fix.t_ms = r.t_ms
    fix.itow_ms = r.itow_ms
    fix.pos_valid = r.pos_valid
    fix.lat_e7 = r.lat_e7
    fix.lat_hp = r.lat_hp
    fix.lon_e7 = r.lon_e7
    fix.lon_hp = r.lon_hp
    fix.rtk = r.rtk
    fix.num_sv = r.num_sv
    fix.h_acc_m = r.h_acc_m
    fix.heading_valid = r.heading_valid
    fix.heading_deg = r.heading_deg
    fix.heading_acc_deg = r.heading_acc_deg
    fix.vel_valid = r.vel_valid
    fix.sog_mps = r.sog_mps
    fix.cog_deg = r.cog_deg


class _Interval:
    """The epoch interval as the app's GNSS parser measures it (gnss.GnssParser._measure, iTOW
    part): the law's time step. Dead-reckoned records (iTOW -1) are skipped."""

    def __init__(self):
        self.interval_ms = 0
        self._prev = -1
        self._cand = 0

    def update(self, itow_ms):
        if itow_ms < 0:
            return
        if self._prev >= 0:
            d = (itow_ms - self._prev) % 604800000
            if 0 < d <= 10000:
                if -5 <= d - self._cand <= 5:
                    self.interval_ms = d
                self._cand = d
        self._prev = itow_ms


def main():
    logs, cfg_path, law_name, sets, csv = _args(sys.argv)
    if not logs:
        raise SystemExit("usage: replay.py LOG.tpl ... [--config CFG] [--law L] [--set S.K=V] [--csv]")
    if cfg_path:
        cfg, problems = config.load(cfg_path)
        for p in problems:
            sys.stderr.write("replay: config: %s\n" % p)
    else:
        cfg = config.defaults()
    if law_name:
        cfg["guidance"]["law"] = law_name
    cfg = _apply_sets(cfg, sets)
    boat = cfg["boat"]
    law = guidance.make_law(cfg["guidance"], boat)
    rule = progress.RULE_SEED if cfg["guidance"]["law"] == "seed" else progress.RULE_ROBUST
    fix = Fix()
    iv = _Interval()
    prog = None
    ref = None
    n_ctrl = n_guided = same_heading = same_speed = 0
    max_diff = 0.0
    sum_sq = 0.0
    damage = 0
    prev_mode = 0
    for path in logs:
        with open(path, "rb") as f:
            data = f.read()
        for r in logfmt.iter_records(data):
            t = r.type
            if t == "track":
                prog = progress.Progress(from_waypoints(r.waypoints), rule)
                law.reset()
            elif t == "damage":
                damage += 1
            elif t == "event" and prog is not None:
                text = r.text
                if r.kind == "NAV" and text.startswith("NEXT_WP"):
                    prog.skip()
                    law.reset()
                elif r.kind == "NAV" and text.startswith("PREV_WP"):
                    prog.back()
                    law.reset()
                elif r.kind == "STATE" and text.startswith("restored: leg "):
                    prog.set_leg(int(text[14:].split(" ")[0]))
                elif r.kind == "MODE" and "->AUTO" in text and ref is not None:
                    if prog.finished:
                        prog.restart()
                    prog.join_nearest(ref[0], ref[1])  # as the app does on ENGAGE
                    law.reset()
            elif t == "control" and prog is not None:
                n_ctrl += 1
                _fill(fix, r)
                guided = bool(getattr(r, "guided", 0))
                iv.update(r.itow_ms)
                new_ref, out = control.guide_epoch(fix, prog, law, boat, guided,
                                                   control.epoch_dt_s(iv.interval_ms))
                if new_ref is not None:
                    ref = new_ref
                prev_mode = r.mode
                if not guided or out is None:
                    continue
                n_guided += 1
                cmd = logfmt.quantized("heading_cmd_deg", out.heading_cmd_deg)
                spd = logfmt.quantized("speed_cmd_mps", out.speed_cmd_mps)
                d = cmd - r.heading_cmd_deg
                d = (d + 180.0) % 360.0 - 180.0
                if cmd == r.heading_cmd_deg:
                    same_heading += 1
                if spd == r.speed_cmd_mps:
                    same_speed += 1
                if abs(d) > max_diff:
                    max_diff = abs(d)
                sum_sq += d * d
                if csv:
                    print("%d,%d,%.2f,%.2f,%.3f,%.3f,%.2f" % (r.t_ms, prog.leg, r.heading_cmd_deg, cmd,
                                                             r.speed_cmd_mps, spd, prog.xte_m))
    rms = (sum_sq / n_guided) ** 0.5 if n_guided else 0.0
    print("SUMMARY law=%s control=%d guided=%d heading_identical=%d speed_identical=%d "
          "max_heading_diff_deg=%.2f rms_heading_diff_deg=%.3f damage=%d" % (
              cfg["guidance"]["law"], n_ctrl, n_guided, same_heading, same_speed, max_diff, rms, damage))
    return prev_mode


main()
