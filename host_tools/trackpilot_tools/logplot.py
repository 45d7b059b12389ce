"""Plots of a decoded log, like the seed report's figures (matplotlib, Agg backend, PNG files).

track.png    planned vs sailed track (east/north metres from the first waypoint)
xte.png      lateral (cross-track) deviation over time, +-1.5 m band
heading.png  GNSS heading vs heading command, and the heading error
speed.png    speed over ground and speed command; RPM setpoint and measured RPM
Mode changes (MODE events) are marked on every plot.

Usage:
    from trackpilot_tools.logdecode import decode_files
    from trackpilot_tools.logplot import plot_all
    paths = plot_all(decode_files(["log/0003-00.tpl"]), "plots/")
"""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from trackpilot_tools.logdecode import AUTO, local_en_m  # noqa: E402


GAP_S = 2.0  # control records come at 5-10 Hz; a longer pause is a gap in the log, drawn as one


def _wrap180(a):
    return (a + 180.0) % 360.0 - 180.0


def _gapped(t, *series):
    """(t, series...) with a NaN inserted wherever consecutive records are more than GAP_S apart,
    so a line stops at a gap instead of bridging it."""
    out_t = []
    outs = [[] for _ in series]
    for i, ti in enumerate(t):
        if i and ti - t[i - 1] > GAP_S:
            out_t.append((ti + t[i - 1]) / 2)
            for o in outs:
                o.append(float("nan"))
        out_t.append(ti)
        for o, s in zip(outs, series):
            o.append(s[i])
    return [out_t] + outs


def _gap_spans(ax, d):
    """Grey bands where the log has no control records (reset, lost power, damaged span)."""
    c = d.controls
    first = True
    for a, b in zip(c, c[1:]):
        if b.t_s - a.t_s > GAP_S:
            ax.axvspan(a.t_s, b.t_s, color="0.85", zorder=0, label="no records" if first else None)
            first = False


def _time_label(d):
    """x axis label: seconds since the log start, with its UTC where a header gives it."""
    from trackpilot_tools.logdecode import utc_of

    utc = utc_of(d, d.controls[0]) if d.controls else ""
    return "time since log start (s)" + (" — start %s UTC" % utc[:19].replace("T", " ") if utc else "")


def _outside_legend(ax, handles=None, labels=None):
    """Legend to the right of the axes, so it never covers data."""
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              borderaxespad=0.0)


def _mode_lines(ax, d, label=True):
    """Vertical lines at mode changes, labelled with the change (e.g. STANDBY->AUTO). Labels of
    changes close in time step down the axis instead of printing over each other."""
    lo, top = ax.get_ylim()
    x0, x1 = ax.get_xlim()
    min_dx = 0.04 * max(x1 - x0, 1e-9)
    last_x, level = None, 0
    for e in d.events:
        if e.kind != "MODE":
            continue
        ax.axvline(e.t_s, color="tab:red", lw=0.8, ls="--", alpha=0.7)
        if label:
            level = level + 1 if last_x is not None and e.t_s - last_x < min_dx else 0
            last_x = e.t_s
            y = top - (level % 3) * 0.33 * (top - lo)
            ax.text(e.t_s, y, " " + e.text.split(":")[0][:24], rotation=90, va="top", ha="left",
                    fontsize=7, color="tab:red")


class _Labels:
    """Point labels in a plot, nudged down while they would sit on an earlier one."""

    def __init__(self, ax, min_sep):
        self.ax = ax
        self.min_sep = min_sep
        self.placed = []  # (x, y, vertical offset in points)

    def add(self, text, p, color, dy=3):
        offsets = [o for x, y, o in self.placed
                   if abs(x - p[0]) < self.min_sep and abs(y - p[1]) < self.min_sep]
        while dy in offsets:
            dy -= 9
        self.placed.append((p[0], p[1], dy))
        self.ax.annotate(text, p, fontsize=7, color=color, xytext=(4, dy), textcoords="offset points")


def _finish(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_track(d, path):
    fig, ax = plt.subplots(figsize=(8, 8))
    wps = d.track.waypoints if d.track else []
    c = [r for r in d.controls if r.pos_valid]
    if wps:
        lat0, lon0 = wps[0].lat_e7, wps[0].lon_e7
    elif c:
        lat0, lon0 = c[0].lat_e7, c[0].lon_e7
    else:
        lat0 = lon0 = 0
    allpts = ([local_en_m(w.lat_e7, 0, w.lon_e7, 0, lat0, lon0) for w in wps]
              + [local_en_m(r.lat_e7, r.lat_hp, r.lon_e7, r.lon_hp, lat0, lon0) for r in c[::50]])
    span = max((max(p[i] for p in allpts) - min(p[i] for p in allpts)) for i in (0, 1)) if allpts else 1.0
    labels = _Labels(ax, 0.04 * max(span, 1.0))
    if wps:
        pts = [local_en_m(w.lat_e7, 0, w.lon_e7, 0, lat0, lon0) for w in wps]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o--", color="tab:gray", lw=1.2, ms=5,
                label="planned track")
        for w, p in zip(wps, pts):
            if w.name:
                labels.add(w.name, p, "tab:gray")
    if c:
        en = [local_en_m(r.lat_e7, r.lat_hp, r.lon_e7, r.lon_hp, lat0, lon0) for r in c]
        auto = [r.mode == AUTO for r in c]
        # Sailed track, AUTO segments solid blue, other modes orange.
        start = 0
        for i in range(1, len(c) + 1):
            if i < len(c) and c[i].t_s - c[i - 1].t_s > GAP_S:  # a gap in the log: no line across
                seg = en[start:i]
                ax.plot([p[0] for p in seg], [p[1] for p in seg], "-",
                        color="tab:blue" if auto[start] else "tab:orange", lw=1.0)
                start = i
                continue
            if i == len(c) or auto[i] != auto[start]:
                seg = en[start : i + 1]
                ax.plot([p[0] for p in seg], [p[1] for p in seg], "-",
                        color="tab:blue" if auto[start] else "tab:orange", lw=1.0)
                start = i
        ax.plot([], [], "-", color="tab:blue", label="sailed (AUTO)")
        ax.plot([], [], "-", color="tab:orange", label="sailed (other modes)")
        ax.plot(*en[0], "g^", ms=8, label="start")
        # Mode changes: marker at the boat's position then.
        j = 0
        for e in d.events:
            if e.kind != "MODE":
                continue
            while j + 1 < len(c) and c[j + 1].t_s <= e.t_s:
                j += 1
            ax.plot(*en[j], "rx", ms=8)
            labels.add(e.text.split(":")[0][:24], en[j], "tab:red", dy=-10)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title("Planned and sailed track")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.plot([], [], "rx", label="mode change")
    _outside_legend(ax)
    fig.set_size_inches(10, 8)
    return _finish(fig, path)


def plot_xte(d, path):
    fig, ax = plt.subplots(figsize=(10, 4))
    t = [r.t_s for r in d.controls]
    ax.plot(*_gapped(t, [r.xte_m for r in d.controls]), lw=0.8, label="cross-track error (+ = starboard)")
    if any(getattr(r, "path_xte_m", 0.0) for r in d.controls):
        ax.plot(*_gapped(t, [r.path_xte_m for r in d.controls]), lw=0.7, alpha=0.8,
                label="against the planned path")
    ax.axhspan(-1.5, 1.5, color="tab:green", alpha=0.1, label="+-1.5 m goal")
    ax.axhline(0, color="k", lw=0.5)
    _gap_spans(ax, d)
    ax.set_xlabel(_time_label(d))
    ax.set_ylabel("lateral deviation (m)")
    ax.set_title("Lateral deviation over time")
    ax.grid(True, alpha=0.3)
    _outside_legend(ax)
    _mode_lines(ax, d)
    return _finish(fig, path)


def plot_heading(d, path):
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True,
                                  gridspec_kw={"height_ratios": [2, 1]})
    c = d.controls
    t = [r.t_s for r in c]
    ax.plot(t, [r.heading_deg for r in c], ".", ms=1.5, label="GNSS heading")
    ax.plot(t, [r.heading_cmd_deg for r in c], ".", ms=1.5, label="heading command")
    ax.plot(t, [r.compass_deg for r in c], ".", ms=1.0, alpha=0.5, label="pilot compass")
    ax.set_ylim(0, 360)
    ax.set_yticks(range(0, 361, 90))
    ax.set_ylabel("heading (deg true)")
    ax.set_title("Heading vs command")
    ax.grid(True, alpha=0.3)
    _gap_spans(ax, d)
    h, lab = ax.get_legend_handles_labels()
    ax.legend(h, lab, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, markerscale=6,
              borderaxespad=0.0)
    _mode_lines(ax, d)
    ax2.plot(*_gapped(t, [_wrap180(r.heading_cmd_deg - r.heading_deg) for r in c]), lw=0.7,
             color="tab:purple")
    ax2.set_ylabel("command - heading (deg)")
    ax2.set_xlabel(_time_label(d))
    ax2.grid(True, alpha=0.3)
    _mode_lines(ax2, d, label=False)
    return _finish(fig, path)


def plot_speed(d, path):
    fig, ax = plt.subplots(figsize=(10, 4))
    c = d.controls
    t = [r.t_s for r in c]
    ax.plot(*_gapped(t, [r.sog_mps for r in c]), lw=0.8, label="speed over ground")
    ax.plot(*_gapped(t, [r.speed_cmd_mps for r in c]), lw=1.0, ls="--", label="speed command")
    _gap_spans(ax, d)
    ax.set_xlabel(_time_label(d))
    ax.set_ylabel("speed (m/s)")
    ax.grid(True, alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(*_gapped(t, [r.rpm_set for r in c]), color="tab:red", lw=1.0, ls="--", label="RPM setpoint")
    ax2.plot(*_gapped(t, [r.rpm for r in c]), color="tab:brown", lw=0.7, label="RPM")
    ax2.set_ylabel("RPM")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, loc="upper left", bbox_to_anchor=(1.08, 1.0), fontsize=8,
              borderaxespad=0.0)
    ax.set_title("Speed and RPM")
    _mode_lines(ax, d)
    return _finish(fig, path)


def plot_all(d, out_dir):
    """Write every plot of a Decoded into out_dir; returns the PNG paths."""
    os.makedirs(out_dir, exist_ok=True)
    return [
        plot_track(d, os.path.join(out_dir, "track.png")),
        plot_xte(d, os.path.join(out_dir, "xte.png")),
        plot_heading(d, os.path.join(out_dir, "heading.png")),
        plot_speed(d, os.path.join(out_dir, "speed.png")),
    ]
