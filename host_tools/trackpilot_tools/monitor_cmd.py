"""`trackpilot monitor`: a live view of the boat, like the seed report's real-time monitor (App. F).

It reads the firmware's status datagrams (docs/TELEMETRY.md) from UDP (default port 10111, as the
boat broadcasts them) or from the USB serial console (lines `TPS <hex>` that the firmware prints
when `telemetry.console` is true), decodes them with the firmware's own `tphmi.status`, and shows
mode, fix and RTK, heading and command, cross-track error, leg and distance, speed and RPM, pilot
state, wind, battery and alarms. A link with no status for `--stale-s` seconds is shown as STALE.
"""
import binascii
import socket
import sys
import time

from trackpilot_tools.mpy import FIRMWARE_DIR, HMI_DIR

for _p in (str(FIRMWARE_DIR), str(HMI_DIR)):
    if _p not in sys.path:
        sys.path.insert(0, _p)

from tphmi.status import alarm_names, decode_status, mode_text  # noqa: E402

RTK = ("none", "single", "float", "FIXED")
PILOT = ("standby", "auto", "wind", "track", "calibration", "?")


def _deg(v):
    return "%5.1f" % v


def render(st, age_s, stale_s, source):
    """The status as text lines (no terminal control codes)."""
    if st is None:
        return ["trackpilot monitor (%s): waiting for status ..." % source]
    link = "LINK STALE: no status for %.1f s" % age_s if age_s > stale_s else "link ok (%.1f s)" % age_s
    lines = [
        "trackpilot monitor  boat %d  seq %d  %s  [%s]" % (st.boat_id, st.seq, source, link),
        "mode    %-22s alarms %s" % (mode_text(st), alarms_text(st)),
    ]
    if st.alarms and st.alarm_reason:  # the reason stays in the status after the alarm clears
        lines.append("alarm   %s" % st.alarm_reason)
    if st.refusal:
        lines.append("refused %s" % st.refusal)
    lines += [
        "fix     %s  RTK %-6s sats %2d  hacc %.3f m  corr age %s" % (
            "%.7f %.7f" % (st.lat_e7 / 1e7, st.lon_e7 / 1e7) if st.pos_valid else "no position",
            RTK[st.rtk] if 0 <= st.rtk < 4 else "?", st.num_sv, st.h_acc_m,
            "-" if st.corr_age_s < 0 else "%.1f s" % st.corr_age_s),
        "heading %s deg %s  command %s deg  sog %.2f m/s" % (
            _deg(st.heading_deg), "   " if st.heading_valid else "BAD",
            _deg(st.heading_cmd_deg) if st.cmd_valid else "  -  ", st.sog_mps),
        "track   xte %+6.2f m  %s  leg %d/%d  to waypoint %.1f m" % (
            st.xte_m, _bar(st.xte_m), st.leg + 1, st.legs, st.to_wp_m) if st.nav_valid else "track   none loaded",
        "motor   rpm cmd %d  rpm %s  battery %s" % (
            st.rpm_cmd, "-" if st.rpm < 0 else st.rpm, "-" if st.battery_v < 0 else "%.2f V" % st.battery_v),
        "pilot   %s %-11s compass %s  locked %s  keys %d  hang recoveries %d" % (
            "ok " if st.pilot_ok else "LOST", PILOT[st.pilot_mode] if 0 <= st.pilot_mode < 6 else "?",
            _deg(st.compass_deg), _deg(st.locked_deg), st.keystrokes, st.hang_recoveries),
        "wind    %s" % ("-" if st.wind_speed_mps < 0 else "%.0f deg apparent, %.1f m/s" % (
            st.wind_angle_deg, st.wind_speed_mps)),
    ]
    return lines


def alarms_text(st):
    """Active alarms, each marked `(ack)` once a person acknowledged it (no longer sounding)."""
    names = alarm_names(st.alarms)
    if not names:
        return "-"
    acked = set(alarm_names(st.alarms & ~st.sounding))
    return ",".join(n + (" (ack)" if n in acked else "") for n in names)


def _bar(xte_m, half=10, full_m=5.0):
    """[....|##..] : # marks the side the boat is on (right = starboard of the leg)."""
    n = int(min(half, round(abs(xte_m) / full_m * half)))
    left = "." * half
    right = "." * half
    if xte_m < 0:
        left = "." * (half - n) + "#" * n
    else:
        right = "#" * n + "." * (half - n)
    return "[%s|%s]" % (left, right)


class UdpSource:
    def __init__(self, port, host="0.0.0.0"):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self.sock.bind((host, port))
        except OSError as e:
            raise SystemExit("monitor: cannot listen on UDP %s:%d: %s" % (host, port, e))
        self.sock.settimeout(0.25)
        self.name = "udp:%d" % port

    def read(self):
        try:
            data, _ = self.sock.recvfrom(2048)
        except socket.timeout:
            return None
        return data


class SerialSource:
    """The USB console: `TPS <hex>` lines among whatever else the board prints."""

    def __init__(self, port, baud):
        import serial

        try:
            self.ser = serial.Serial(port, baud, timeout=0.25)
        except (serial.SerialException, OSError) as e:
            raise SystemExit("monitor: cannot open serial port %s: %s" % (port, e))
        self.name = "serial:%s" % port
        self.buf = b""

    def read(self):
        self.buf += self.ser.read(512)
        while b"\n" in self.buf:
            line, self.buf = self.buf.split(b"\n", 1)
            line = line.strip()
            if line.startswith(b"TPS "):
                try:
                    return binascii.unhexlify(line[4:])
                except (binascii.Error, ValueError):
                    continue
        if len(self.buf) > 4096:
            self.buf = self.buf[-4096:]
        return None


def _check_numbers(args):
    """The monitor's counts and times: one line for a value it cannot wait on."""
    from trackpilot_tools.errors import UserError

    for name in ("stale_s", "history_s"):
        v = getattr(args, name, None)
        if v is not None and not 0.0 < v < 1e7:  # also false for NaN
            raise UserError("--%s must be seconds > 0" % name.replace("_", "-"))
    if not 0.0 <= args.duration < 1e7:
        raise UserError("--duration must be seconds >= 0 (0: until stopped)")
    if args.count < 0:
        raise UserError("--count must be datagrams >= 0 (0: until stopped)")


def _source(args):
    from trackpilot_tools.errors import check_port

    _check_numbers(args)
    check_port("--udp", args.udp)
    if args.web:
        check_port("--http-port", args.http_port)
    try:
        return SerialSource(args.serial, args.baud) if args.serial else UdpSource(args.udp, args.udp_host)
    except SystemExit as e:  # the sources' own one-line reasons
        from trackpilot_tools.errors import UserError

        raise UserError(str(e).replace("monitor: ", "", 1))


def cmd_web(args):
    from trackpilot_tools import webmon

    track = None
    if args.track:
        from trackpilot.nav.track import TrackError

        from trackpilot_tools.errors import UserError

        try:
            track = webmon.load_track(args.track)
        except OSError as e:
            raise UserError("cannot read track %s: %s" % (args.track, e.strerror or e))
        except TrackError as e:
            raise UserError("%s: %s" % (args.track, e))
    book = webmon.Book(track, history_s=args.history_s, stale_s=args.stale_s)
    src = _source(args)
    webmon.serve(src, book, args.http_host, args.http_port, args.duration, out=lambda m: print(m, flush=True))
    print("monitor: %d status datagrams, %d bad" % (book.count, book.bad), file=sys.stderr)
    return 0


def cmd_monitor(args):
    if args.web:
        return cmd_web(args)
    src = _source(args)
    print("monitor: listening on %s" % src.name, file=sys.stderr, flush=True)  # ready: send now
    tty = sys.stdout.isatty() and not args.plain
    st = None
    last_rx = None
    count = bad = 0
    t_end = time.monotonic() + args.duration if args.duration else None
    last_draw = 0.0
    last_state = None
    while True:
        now = time.monotonic()
        if t_end is not None and now >= t_end:
            break
        data = src.read()
        if data is not None:
            try:
                new = decode_status(data)
                if args.boat is not None and new.boat_id != args.boat:
                    continue  # another boat's status: the text view shows one boat
                st = new
                last_rx = time.monotonic()
                count += 1
            except ValueError as e:
                bad += 1
                print("monitor: bad datagram (%s)" % e, file=sys.stderr)
        age = (time.monotonic() - last_rx) if last_rx is not None else 0.0
        stale = last_rx is not None and age > args.stale_s
        if tty:
            if time.monotonic() - last_draw > 0.2:
                sys.stdout.write("\x1b[H\x1b[2J" + "\n".join(render(st, age, args.stale_s, src.name)) + "\n")
                sys.stdout.flush()
                last_draw = time.monotonic()
        else:
            state = (count, stale)
            if state != last_state and (data is not None or stale):
                print(" | ".join(render(st, age, args.stale_s, src.name)))
                sys.stdout.flush()
                last_state = state
        if args.count and count >= args.count:
            break
    print("monitor: %d status datagrams, %d bad" % (count, bad), file=sys.stderr)
    return 0


def add_parser(p):
    p.add_argument("--udp", type=int, default=10111, help="UDP port of the status datagrams (default 10111)")
    p.add_argument("--udp-host", default="0.0.0.0",
                   help="local address to listen on (default 0.0.0.0: every interface, broadcasts too)")
    p.add_argument("--serial", help="read `TPS <hex>` lines from this serial port instead (USB console)")
    p.add_argument("--baud", type=int, default=115200)
    p.add_argument("--stale-s", type=float, default=3.0, help="show the link as stale after this long")
    p.add_argument("--plain", action="store_true", help="one line per update instead of a live screen")
    p.add_argument("--count", type=int, default=0, help="stop after this many datagrams")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds")
    p.add_argument("--boat", type=int, help="text view: show only this boat id (default: whatever arrives)")
    w = p.add_argument_group("web view (--web)")
    w.add_argument("--web", action="store_true",
                   help="serve a live page instead: map of the boats on the track, xte and heading charts, "
                        "every boat by id (read-only)")
    w.add_argument("--http-host", default="127.0.0.1",
                   help="interface of the page (default 127.0.0.1: this computer only; 0.0.0.0: the LAN)")
    w.add_argument("--http-port", type=int, default=8080, help="port of the page (default 8080)")
    w.add_argument("--track", help="the track file the boat sails, to draw the planned path and the current leg")
    w.add_argument("--history-s", type=float, default=600.0, help="minutes of history in charts and trails, in s (default 600)")
    p.set_defaults(func=cmd_monitor)
