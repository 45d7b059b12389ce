"""Display pages for the 128x64 OLED, drawn from an HmiStatus onto any framebuf.FrameBuffer.

Pages (PAGE_NAMES, cycled by the PAGE button):
    main    mode, RTK state, cross-track error (2x digits, L/R) with a left/right bar, heading vs
            command, speed and RPM, leg i/N with the distance to the next waypoint
    gnss    RTK state, satellites, accuracy, heading and its accuracy, correction age, position
    pilot   trackpilot mode, the pilot's mode, compass, locked course, keystrokes (or "HUNTS:lower gain"
            while the pilot watch reports hunting), hang recoveries
    alarms  active alarms (! = sounding, not acknowledged), the latest reason, the E-stop input
Overlays on every page: the E-stop input (header), an engage refusal with its reason, the AUTO
hold progress, and a short transient message. The remote box draws `link_lost()` instead of the
pages when telemetry stops. The 8x8 framebuf font gives 16 columns x 8 rows.

Bar convention: xte_m > 0 (boat starboard of the leg) draws the bar right of the centre, and the
number reads "R"; the bar is clamped at +-xte_full_m with an arrow head at the edge.

Usage:
    import framebuf
    buf = bytearray(128 * 64 // 8)
    fb = framebuf.FrameBuffer(buf, 128, 64, framebuf.MONO_VLSB)   # or SSD1306(...).fb
    pages = Pages(fb)
    pages.render(status, PAGE_MAIN, t_ms)          # then oled.show()
    pages.message("hold AUTO 1 s", t_ms, 2000)      # transient line at the bottom
"""
import framebuf

from trackpilot.compat import const, ticks_diff

from tphmi.status import (
    MODE_ESTOP,
    PILOT_MODE_NAMES,
    RTK_NAMES,
    alarm_names,
    mode_text,
)

PAGE_MAIN = const(0)
PAGE_GNSS = const(1)
PAGE_PILOT = const(2)
PAGE_ALARMS = const(3)
N_PAGES = const(4)
_WIFI_SHORT = ("", "wf?", "WiFi", "wf-")  # off (not shown), connecting, up, retry
PAGE_NAMES = ("main", "gnss", "pilot", "alarms")

_RTK_SHORT = ("---", "SGL", "FLT", "FIX")
_COLS = const(16)
BAR_Y = const(28)  # top row of the xte bar
BAR_H = const(7)
XTE_Y = const(11)  # top row of the 2x xte digits


def wrap(text, width=_COLS, max_lines=3):
    """Split text into lines of at most `width` characters, at spaces where possible."""
    lines = []
    words = text.split()
    line = ""
    for w in words:
        while len(w) > width:  # hard-break a long word
            if line:
                lines.append(line)
                line = ""
            lines.append(w[:width])
            w = w[width:]
        if not line:
            line = w
        elif len(line) + 1 + len(w) <= width:
            line = line + " " + w
        else:
            lines.append(line)
            line = w
    if line:
        lines.append(line)
    if len(lines) > max_lines:
        lines = lines[:max_lines]
        last = lines[-1]
        lines[-1] = (last[: width - 1] if len(last) >= width else last) + "~"
    return lines


def lat_lon_text(v_e7, pos, neg):
    """1e-7 deg int -> 'N 51.4987654' without a float."""
    h = pos if v_e7 >= 0 else neg
    a = -v_e7 if v_e7 < 0 else v_e7
    return "%s %d.%07d" % (h, a // 10000000, a % 10000000)


def xte_text(st):
    """5 characters for the 2x xte number: ' 1.2R', '12.3L', ' 123R', '--.- '."""
    if not st.nav_valid:
        return "--.- "
    x = st.xte_m
    side = "R" if x > 0.05 else ("L" if x < -0.05 else " ")
    a = -x if x < 0 else x
    if a < 99.95:
        return "%4.1f%s" % (a, side)
    if a > 999:
        a = 999
    return "%4d%s" % (int(a), side)


class Pages:
    """Renders HmiStatus pages into `fb` (a framebuf.FrameBuffer, width x height)."""

    def __init__(self, fb, width=128, height=64, xte_full_m=10.0):
        self.fb = fb
        self.width = width
        self.height = height
        self.xte_full_m = xte_full_m  # bar full scale, each side
        # Scratch for the 2x font: one row of up to 16 characters.
        self._sbuf = bytearray(_COLS * 8)
        self._sfb = framebuf.FrameBuffer(self._sbuf, _COLS * 8, 8, framebuf.MONO_VLSB)
        self._msg = ""
        self._msg_t0 = 0
        self._msg_ms = 0

    # ------------------------------------------------------------------ drawing helpers
    def text(self, s, x, y, c=1):
        self.fb.text(s, x, y, c)

    def text_right(self, s, y, c=1):
        self.fb.text(s, self.width - 8 * len(s), y, c)

    def label(self, s, x, y):
        """Inverted text (white box, black letters)."""
        self.fb.fill_rect(x, y, 8 * len(s) + 2, 9, 1)
        self.fb.text(s, x + 1, y + 1, 0)

    def text2x(self, s, x, y, c=1):
        """Text at double size (16x16 per character)."""
        n = len(s)
        if n > _COLS:
            n = _COLS
            s = s[:n]
        sfb = self._sfb
        sbuf = self._sbuf
        sfb.fill(0)
        sfb.text(s, 0, 0, 1)
        fill_rect = self.fb.fill_rect
        for col in range(8 * n):
            b = sbuf[col]
            if b:
                for row in range(8):
                    if b & (1 << row):
                        fill_rect(x + 2 * col, y + 2 * row, 2, 2, c)

    def title(self, s, st, t_ms):
        """Header row: inverted title left, E-stop input or RTK state right."""
        self.fb.fill_rect(0, 0, self.width, 9, 0)
        if st.estop_input:
            self.fb.fill_rect(0, 0, self.width, 9, 1)
            self.fb.text("E-STOP INPUT ON", 4, 1, 0)
            return
        self.label(s, 0, 0)
        if st.alarms:
            x = 8 * len(s) + 6
            if st.sounding and (t_ms // 250) % 2:
                self.fb.fill_rect(x - 1, 0, 10, 9, 1)
                self.fb.text("!", x, 1, 0)
            else:
                self.fb.text("!", x, 1, 1)
        self.text_right(_RTK_SHORT[st.rtk] if 0 <= st.rtk < 4 and st.pos_valid else "---", 1)

    def message(self, text, t_ms, duration_ms=2000):
        """Show a short transient message (one line) at the bottom of every page."""
        self._msg = text[:_COLS]
        self._msg_t0 = t_ms
        self._msg_ms = duration_ms

    # ------------------------------------------------------------------ pages
    def render(self, st, page, t_ms=0, engage_progress=0.0):
        """Draw page `page` (PAGE_*) for status `st` at time t_ms (blinking, transient message)."""
        self.fb.fill(0)
        page = page % N_PAGES
        if page == PAGE_MAIN:
            self._main(st, t_ms)
        elif page == PAGE_GNSS:
            self._gnss(st, t_ms)
        elif page == PAGE_PILOT:
            self._pilot(st, t_ms)
        else:
            self._alarms(st, t_ms)
        self._overlays(st, t_ms, engage_progress)

    def xte_bar(self, xte_m, valid):
        """Left/right bar: centre at width/2, positive xte to the right, clamped with an arrow."""
        fb = self.fb
        w = self.width
        mid = w // 2
        y = BAR_Y
        fb.rect(0, y, w, BAR_H, 1)
        for q in (w // 4, 3 * w // 4):  # half-scale ticks
            fb.vline(q, y - 2, 2, 1)
            fb.vline(q, y + BAR_H, 2, 1)
        fb.vline(mid, y - 3, BAR_H + 6, 1)
        if not valid:
            return
        half = mid - 2
        n = int(abs(xte_m) / self.xte_full_m * half + 0.5)
        clamped = n > half
        if clamped:
            n = half
        if n <= 0:
            return
        # Filled bar from the centre; when clamped a black arrow head at the edge points outwards.
        if xte_m > 0:
            fb.fill_rect(mid + 1, y + 1, n, BAR_H - 2, 1)
            if clamped:
                for k in range(3):
                    fb.vline(w - 3 - k, y + 3 - k, 1 + 2 * k, 0)
        else:
            fb.fill_rect(mid - n, y + 1, n, BAR_H - 2, 1)
            if clamped:
                for k in range(3):
                    fb.vline(2 + k, y + 3 - k, 1 + 2 * k, 0)

    def _main(self, st, t_ms):
        self.title(mode_text(st), st, t_ms)
        self.text2x(xte_text(st), 0, XTE_Y)
        self.text("XTE", 84, XTE_Y)
        self.text("m", 84, XTE_Y + 8)
        self.xte_bar(st.xte_m, st.nav_valid)
        hdg = "%3d" % (int(st.heading_deg + 0.5) % 360) if st.heading_valid else "---"
        cmd = "%3d" % (int(st.heading_cmd_deg + 0.5) % 360) if st.cmd_valid else "---"
        self.text("HDG %s CMD %s" % (hdg, cmd), 0, 38)
        rpm = st.rpm if st.rpm >= 0 else st.rpm_cmd
        self.text("%4.1fkm/h %4drpm" % (st.sog_mps * 3.6, rpm), 0, 47)
        if st.nav_valid and st.legs > 0:
            d = st.to_wp_m
            dist = "%5dm" % int(d + 0.5) if d < 99999.5 else ">100km"
            self.text("LEG %d/%d" % (st.leg + 1, st.legs), 0, 56)
            self.text_right(dist, 56)
        else:
            self.text("NO TRACK", 0, 56)

    def _gnss(self, st, t_ms):
        self.title("GNSS", st, t_ms)
        rtk = RTK_NAMES[st.rtk] if 0 <= st.rtk < 4 and st.pos_valid else "no fix"
        self.text("RTK %s" % rtk, 0, 11)
        if st.wifi:  # Wi-Fi station: the corrections come over it
            self.text_right(_WIFI_SHORT[st.wifi & 3], 11)
        self.text("SV %2d acc%5.2fm" % (st.num_sv, st.h_acc_m if st.h_acc_m < 99.99 else 99.99), 0, 20)
        if st.heading_valid:
            acc = st.heading_acc_deg if st.heading_acc_deg < 9.9 else 9.9
            self.text("HDG %5.1f +-%3.1f" % (st.heading_deg, acc), 0, 29)
        else:
            self.text("HDG invalid", 0, 29)
        if st.corr_age_s < 0:
            self.text("corr   ---", 0, 38)
        else:
            self.text("corr %5.1fs" % (st.corr_age_s if st.corr_age_s < 999 else 999.0), 0, 38)
        if st.gnss_cfg_failed:  # the receiver did not take our configuration (docs/GNSS.md)
            self.text_right("CFG!", 38)
        if st.pos_valid:
            self.text(lat_lon_text(st.lat_e7, "N", "S"), 0, 47)
            self.text(lat_lon_text(st.lon_e7, "E", "W"), 0, 56)
        else:
            self.text("no position", 0, 47)

    def _pilot(self, st, t_ms):
        self.title("PILOT", st, t_ms)
        self.text("TP  %s" % mode_text(st), 0, 11)
        if st.pilot_ok:
            pm = st.pilot_mode
            self.text("ST  %s" % (PILOT_MODE_NAMES[pm] if 0 <= pm < len(PILOT_MODE_NAMES) else "?"), 0, 20)
            self.text("compass   %5.1f" % st.compass_deg, 0, 29)
            self.text("locked    %5.1f" % st.locked_deg, 0, 38)
        else:
            self.text("ST  NO STATUS", 0, 20)
            self.text("compass     ---", 0, 29)
            self.text("locked      ---", 0, 38)
        if st.pilot_hunts:  # its own loop swings: only a person can turn its gain down
            self.text("HUNTS:lower gain", 0, 47)
        else:
            self.text("keys %10d" % st.keystrokes, 0, 47)
        self.text("hang rec %6d" % st.hang_recoveries, 0, 56)

    def _alarms(self, st, t_ms):
        names = alarm_names(st.alarms)
        self.title("ALARMS %d" % len(names), st, t_ms)
        y = 11
        if not names:
            self.text("no alarms", 0, y)
            y += 9
        else:
            sounding = alarm_names(st.sounding)
            # two names per row: "!gnss   pilot hang" does not fit; one per row, up to 3
            for i in range(len(names)):
                if i == 3:
                    self.text_right("+%d" % (len(names) - 3), y - 9)
                    break
                n = names[i]
                self.text(("!" if n in sounding else " ") + n, 0, y)
                y += 9
        for line in wrap(st.alarm_reason, _COLS, (54 - y) // 9 + 1):
            if y > 47:
                break
            self.text(line, 0, y)
            y += 9
        self.text("E-stop %s" % ("ACTIVE" if st.estop_input else ("latched" if st.mode == MODE_ESTOP else "off")), 0, 56)

    def _overlays(self, st, t_ms, engage_progress):
        fb = self.fb
        if st.refusal:
            lines = wrap(st.refusal, _COLS, 2)
            top = 64 - 9 * (len(lines) + 1) - 1
            fb.fill_rect(0, top, self.width, 64 - top, 1)
            fb.text("AUTO REFUSED:", 1, top + 1, 0)
            y = top + 10
            for line in lines:
                fb.text(line, 0, y, 0)
                y += 9
        if engage_progress > 0.0:  # AUTO being held: label and a filling bar in the last row
            fb.fill_rect(0, 55, self.width, 9, 0)
            fb.text("HOLD AUTO", 0, 56, 1)
            fb.rect(76, 56, self.width - 76, 8, 1)
            fb.fill_rect(78, 58, int((self.width - 80) * engage_progress), 4, 1)
        if self._msg:
            if ticks_diff(t_ms, self._msg_t0) >= self._msg_ms:
                self._msg = ""
            else:
                fb.fill_rect(0, 55, self.width, 9, 1)
                fb.text(self._msg, (self.width - 8 * len(self._msg)) // 2, 56, 0)

    def link_lost(self, age_s, last=None):
        """Remote box: no status for age_s seconds (last: the last HmiStatus received or None)."""
        fb = self.fb
        fb.fill(0)
        fb.fill_rect(0, 0, self.width, 9, 1)
        fb.text("REMOTE", 1, 1, 0)
        self.text2x("NO LINK", 8, 12)
        fb.rect(0, 10, self.width, 20, 1)
        if age_s < 0:
            self.text("no status yet", 0, 34)
        else:
            self.text("no status %4ds" % (age_s if age_s < 9999 else 9999), 0, 34)
        if last is not None:
            self.text("last: %s" % mode_text(last)[:10], 0, 44)
        self.text("state UNKNOWN", 0, 55)
