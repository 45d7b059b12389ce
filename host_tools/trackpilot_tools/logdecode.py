"""Decode trackpilot logs on the host with the firmware's own decoder (trackpilot.record.logfmt).

Usage:
    from trackpilot_tools.logdecode import decode_files, summarize, write_csv
    d = decode_files(["log/0003-00.tpl", "log/0003-01.tpl"])
    d.controls[0].lat_e7, d.controls[0].t_s      # every record also gets t_s (seconds from start)
    print(summarize(d))                           # RMS/max xte, duration, keystrokes, alarms ...
    write_csv(d, "out.csv")
"""
import csv
import math
import os
import re
import sys

from trackpilot_tools.mpy import FIRMWARE_DIR

if str(FIRMWARE_DIR) not in sys.path:
    sys.path.insert(0, str(FIRMWARE_DIR))

from trackpilot.record import logfmt  # noqa: E402
from trackpilot.compat import ticks_diff  # noqa: E402

try:  # names for modes and alarm bits (the lead's module); numbers only if it is missing
    from trackpilot.core.modes import ALARM_NAMES, MODE_NAMES  # noqa: E402
except ImportError:  # pragma: no cover
    ALARM_NAMES = ()
    MODE_NAMES = ()
try:
    from trackpilot.devices.seatalk import MODE_NAMES as PILOT_MODE_NAMES  # noqa: E402
except ImportError:  # pragma: no cover
    PILOT_MODE_NAMES = ()

AUTO = 1  # modes.AUTO
_M_PER_DEG = 6371008.8 * math.pi / 180.0  # mean Earth radius: only for plots and distance sums

# CSV columns of a control record, in logfmt.FIELDS order ("flags" expanded).
CONTROL_COLUMNS = []
for _f in logfmt.FIELDS:
    if _f[0] == "flags":
        CONTROL_COLUMNS += ["pos_valid", "heading_valid", "vel_valid", "rtk"]
    else:
        CONTROL_COLUMNS.append(_f[0])


class LogError(Exception):
    """A file that cannot be read or holds no log at all."""


class Decoded:
    """Everything decoded from one or more files, in file order. Every record has `t_s` (seconds
    since the first control record, ticks unwrapped) and `file` (the path it came from)."""

    def __init__(self):
        self.files = []
        self.headers = []
        self.controls = []
        self.events = []
        self.track = None  # the last TrackRecord seen (waypoints)
        self.damage = []  # Damage records (with .file)
        self.bytes = 0

    @property
    def lost_control(self):
        return sum(d.records for d in self.damage)


SESSION_GAP_S = 60.0  # seconds put between two sessions on one time axis


def session_key(path):
    """Sort key: (session, part) from 'SSSS-PP.tpl', else the name."""
    m = re.match(r"^(\d+)-(\d+)\.tpl$", os.path.basename(str(path)))
    return (0, int(m.group(1)), int(m.group(2)), "") if m else (1, 0, 0, str(path))


def decode_bytes(data, name="", into=None):
    d = into if into is not None else Decoded()
    d.files.append(name)
    d.bytes += len(data)
    clock = getattr(d, "_clock", None)  # (t_s, t_ms) of the last timed record
    for rec in logfmt.iter_records(data):
        rec.file = name
        if rec.type in ("control", "event"):
            if clock is None:
                rec.t_s = 0.0
            else:
                dt = ticks_diff(rec.t_ms, clock[1])
                if dt <= -1000 or (rec.type == "control" and dt >= 3600000):
                    # another session (ticks restarted): continue the time axis after a gap, so a
                    # window reaching a few seconds back from its start does not take the last
                    # session's end (tune's trial cut starts 5 s before the trial)
                    dt = int(SESSION_GAP_S * 1000)
                rec.t_s = clock[0] + dt / 1000.0
            if rec.type == "control" or clock is None:
                clock = (rec.t_s, rec.t_ms)
        if rec.type == "control":
            d.controls.append(rec)
        elif rec.type == "event":
            d.events.append(rec)
        elif rec.type == "header":
            d.headers.append(rec)
        elif rec.type == "track":
            d.track = rec
        else:
            d.damage.append(rec)
    d._clock = clock
    return d


def decode_files(paths):
    """Decode log files (sorted into session/part order) into one Decoded. Raises LogError."""
    return decode_files_in_order(sorted(paths, key=session_key))


def decode_files_in_order(paths):
    """decode_files without the sorting, for files whose names do not tell their order (two
    folders, each with its own 0001-00.tpl): in the order the caller knows they were written."""
    d = Decoded()
    for p in paths:
        try:
            with open(p, "rb") as f:
                data = f.read()
        except OSError as e:
            raise LogError("cannot read %s: %s" % (p, e.strerror or e))
        n_before = len(d.headers) + len(d.controls) + len(d.events)
        decode_bytes(data, str(p), d)
        if len(d.headers) + len(d.controls) + len(d.events) == n_before:
            raise LogError("%s: no trackpilot log records found (%d bytes)" % (p, len(data)))
    return d


def lat_lon_deg_text(e7, hp):
    """Exact decimal degrees from the integer parts, e.g. (514950000, -3) -> '51.494999997'."""
    v = e7 * 100 + hp
    sign = "-" if v < 0 else ""
    v = abs(v)
    return "%s%d.%09d" % (sign, v // 1000000000, v % 1000000000)


RTK_NAMES = ("none", "single", "float", "fixed")  # the control record's 2-bit rtk code


def pilot_mode_name(code):
    return PILOT_MODE_NAMES[code] if 0 <= code < len(PILOT_MODE_NAMES) else str(code)


def header_utc(h):
    """The UTC datetime a header records for its t0_ms, or None (the boat often boots before a fix)."""
    import datetime

    text = (h.get("utc") or "").strip()
    if not text:
        return None
    try:
        dt = datetime.datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        return None
    return dt if dt.tzinfo else dt.replace(tzinfo=datetime.timezone.utc)


def utc_of(d, rec):
    """ISO UTC of a control or event record where the header of its file gives UTC, else ''."""
    import datetime

    for h in d.headers:
        if h.file == rec.file:
            base = header_utc(h)
            if base is None:
                return ""
            try:
                t0 = int(h.get("t0_ms") or 0)
            except ValueError:
                return ""
            dt = base + datetime.timedelta(milliseconds=ticks_diff(rec.t_ms, t0))
            return dt.strftime("%Y-%m-%dT%H:%M:%S.") + "%03dZ" % (dt.microsecond // 1000)
    return ""


def write_csv(d, out):
    """Control records to CSV (one row each): t_s, utc (where known), then CONTROL_COLUMNS, the
    codes' names (mode, pilot mode, RTK, alarms), then lat/lon degrees."""
    cols = (["t_s", "utc", "key"] + CONTROL_COLUMNS
            + ["mode_name", "pilot_mode_name", "rtk_name", "alarm_names", "lat_deg", "lon_deg"])
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in d.controls:
            row = ["%.3f" % r.t_s, utc_of(d, r), int(r.key)]
            for c in CONTROL_COLUMNS:
                v = getattr(r, c, "")
                row.append(int(v) if isinstance(v, bool) else v)
            row += [mode_name(r.mode), pilot_mode_name(r.pilot_mode),
                    RTK_NAMES[r.rtk] if 0 <= r.rtk < 4 else str(r.rtk), "|".join(alarm_names(r.alarms))]
            row.append(lat_lon_deg_text(r.lat_e7, r.lat_hp))
            row.append(lat_lon_deg_text(r.lon_e7, r.lon_hp))
            w.writerow(row)
    return len(d.controls)


def write_events_csv(d, out):
    """Events and damage reports to CSV in log order: t_s, utc, kind, text (damage: kind DAMAGE)."""
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "utc", "kind", "text", "file"])
        for e in d.events:
            w.writerow(["%.3f" % e.t_s, utc_of(d, e), e.kind, e.text, e.file])
        for x in d.damage:
            w.writerow(["", "", "DAMAGE", "@%d: %d bytes, %s, %d control records lost"
                        % (x.offset, x.length, x.reason, x.records), x.file])
    return len(d.events) + len(d.damage)


def alarm_names(bits):
    names = [n for b, n in ALARM_NAMES if bits & b]
    rest = bits
    for b, _n in ALARM_NAMES:
        rest &= ~b
    if rest:
        names.append("0x%x" % rest)
    return names


def mode_name(mode):
    return MODE_NAMES[mode] if 0 <= mode < len(MODE_NAMES) else str(mode)


def local_en_m(lat_e7, lat_hp, lon_e7, lon_hp, lat0_e7, lon0_e7):
    """East/north metres from a reference point (equirectangular; for plots, not navigation)."""
    dlat = ((lat_e7 - lat0_e7) * 100 + lat_hp) * 1e-9
    dlon = ((lon_e7 - lon0_e7) * 100 + lon_hp) * 1e-9
    return (dlon * _M_PER_DEG * math.cos(math.radians(lat0_e7 * 1e-7)), dlat * _M_PER_DEG)


def summarize(records):
    """Key numbers of a run. `records`: a Decoded, or an iterable of decoded records.
    xte statistics are over AUTO-mode records with a valid position (all records if none)."""
    if isinstance(records, Decoded):
        d = records
    else:
        d = Decoded()
        for r in records:
            if r.type == "control":
                d.controls.append(r)
            elif r.type == "event":
                d.events.append(r)
            elif r.type == "damage":
                d.damage.append(r)
            elif r.type == "header":
                d.headers.append(r)
    c = d.controls
    if c and not hasattr(c[0], "t_s"):  # raw iter_records output: build the time axis here
        c[0].t_s = 0.0
        for i in range(1, len(c)):
            c[i].t_s = c[i - 1].t_s + ticks_diff(c[i].t_ms, c[i - 1].t_ms) / 1000.0
    auto = [r for r in c if r.mode == AUTO and r.pos_valid]
    xs = [r.xte_m for r in (auto or c)]
    keys = 0
    bits = 0
    dist = 0.0
    for i, r in enumerate(c):
        bits |= r.alarms
        if i:
            p = c[i - 1]
            if r.keys_sent >= p.keys_sent:  # cumulative; restarts with a new session
                keys += r.keys_sent - p.keys_sent
            if r.pos_valid and p.pos_valid:
                e, n = local_en_m(r.lat_e7, r.lat_hp, r.lon_e7, r.lon_hp, p.lat_e7, p.lon_e7)
                e0, n0 = local_en_m(p.lat_e7, p.lat_hp, p.lon_e7, p.lon_hp, p.lat_e7, p.lon_e7)
                dist += math.hypot(e - e0, n - n0)
    auto_s = 0.0
    for i in range(1, len(c)):
        if c[i - 1].mode == AUTO:
            auto_s += c[i].t_s - c[i - 1].t_s
    duration = (c[-1].t_s - c[0].t_s) if c else 0.0
    return {
        "duration_s": round(duration, 3),
        "control_records": len(c),
        "events": len(d.events),
        "auto_s": round(auto_s, 3),
        "xte_rms_m": round(math.sqrt(sum(x * x for x in xs) / len(xs)), 3) if xs else None,
        "xte_max_abs_m": round(max(abs(x) for x in xs), 3) if xs else None,
        "xte_within_1p5m_frac": round(sum(1 for x in xs if abs(x) <= 1.5) / len(xs), 4) if xs else None,
        "distance_m": round(dist, 1),
        "keystrokes": keys,
        "alarms": alarm_names(bits),
        "alarm_events": sum(1 for e in d.events if e.kind == "ALARM"),
        "mode_changes": sum(1 for e in d.events if e.kind == "MODE"),
        "damage_reports": len(d.damage),
        "damaged_bytes": sum(x.length for x in d.damage if x.reason != "no keyframe"),
        "lost_control_records": sum(x.records for x in d.damage),
    }
