"""`trackpilot monitor --web`: the live monitor as a page in the browser.

One thread reads the status datagrams (UDP or the USB console, the sources of the text monitor),
decodes them with the firmware's own `tphmi.status` and keeps, per boat id, the latest status and
the last minutes of history. A small HTTP server (the standard library's: a read-only page for one
laptop needs no framework, and nothing extra has to be installed on the water) serves the static
page from `web/` in this package and the state as JSON at `/api/state`; the page polls it twice a
second. Read-only: the server answers GET and HEAD only; nothing on the page sends a command.
"""
import json
import math
import threading
import time
from collections import deque
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from trackpilot_tools.monitor_cmd import RTK, PILOT, decode_status, mode_text  # noqa: F401
from tphmi.status import alarm_names  # noqa: E402 (monitor_cmd put hmi/ on sys.path)

WEB_DIR = Path(__file__).with_name("web")
STATIC = {"/": ("index.html", "text/html; charset=utf-8"),
          "/index.html": ("index.html", "text/html; charset=utf-8"),
          "/monitor.js": ("monitor.js", "text/javascript; charset=utf-8"),
          "/monitor.css": ("monitor.css", "text/css; charset=utf-8")}
M_PER_DEG_LAT = 6371008.8 * math.pi / 180.0  # mean Earth radius; for the picture, not navigation


class LocalFrame:
    """East/north metres from an origin given in integer 1e-7 deg (equirectangular: a few km)."""

    def __init__(self, lat0_e7, lon0_e7):
        self.lat0_e7 = lat0_e7
        self.lon0_e7 = lon0_e7
        self.k_lon = M_PER_DEG_LAT * math.cos(math.radians(lat0_e7 * 1e-7))

    def en(self, lat_e7, lon_e7):
        return ((lon_e7 - self.lon0_e7) * 1e-7 * self.k_lon, (lat_e7 - self.lat0_e7) * 1e-7 * M_PER_DEG_LAT)


class Boat:
    def __init__(self, boat_id, history_s):
        self.id = boat_id
        self.st = None
        self.last_rx = None
        self.count = 0
        self.lost = 0  # datagrams missing by seq
        self.history = deque()
        self.history_s = history_s

    def add(self, st, now, frame):
        if self.st is not None:
            gap = (st.seq - self.st.seq - 1) & 0xFFFF
            if gap < 1000:  # a larger jump is a restart, not loss
                self.lost += gap
        self.st = st
        self.last_rx = now
        self.count += 1
        e = n = None
        if st.pos_valid and frame is not None:
            e, n = frame.en(st.lat_e7, st.lon_e7)
        self.history.append((now, e, n, st.xte_m if st.nav_valid else None,
                             st.heading_deg if st.heading_valid else None,
                             st.heading_cmd_deg if st.cmd_valid else None))
        while self.history and now - self.history[0][0] > self.history_s:
            self.history.popleft()

    def to_json(self, now, stale_s, frame):
        st = self.st
        age = now - self.last_rx
        e = n = None
        if st.pos_valid and frame is not None:
            e, n = frame.en(st.lat_e7, st.lon_e7)
        acked = set(alarm_names(st.alarms & ~st.sounding))
        h = self.history

        def r(v, nd):
            return None if v is None else round(v, nd)
        return {
            "id": self.id, "seq": st.seq, "count": self.count, "lost": self.lost,
            "age_s": round(age, 2), "stale": age > stale_s,
            "mode": st.mode, "mode_text": mode_text(st),
            "alarms": [{"name": a, "ack": a in acked} for a in alarm_names(st.alarms)],
            "alarm_reason": st.alarm_reason if st.alarms else "",
            "refusal": st.refusal,
            "pos_valid": bool(st.pos_valid), "e": r(e, 2), "n": r(n, 2),
            "lat": st.lat_e7 / 1e7 if st.pos_valid else None, "lon": st.lon_e7 / 1e7 if st.pos_valid else None,
            "rtk": RTK[st.rtk] if 0 <= st.rtk < 4 else "?", "num_sv": st.num_sv,
            "heading_valid": bool(st.heading_valid), "heading_deg": r(st.heading_deg, 1),
            "cmd_valid": bool(st.cmd_valid), "heading_cmd_deg": r(st.heading_cmd_deg, 1),
            "nav_valid": bool(st.nav_valid), "xte_m": r(st.xte_m, 2), "leg": st.leg, "legs": st.legs,
            "to_wp_m": r(st.to_wp_m, 1), "sog_mps": r(st.sog_mps, 2),
            "rpm_cmd": st.rpm_cmd, "rpm": st.rpm, "battery_v": r(st.battery_v, 2),
            "pilot_ok": bool(st.pilot_ok), "pilot_mode": PILOT[st.pilot_mode] if 0 <= st.pilot_mode < 6 else "?",
            "history": {
                "t": [round(x[0] - now, 2) for x in h],
                "e": [r(x[1], 2) for x in h], "n": [r(x[2], 2) for x in h],
                "xte": [r(x[3], 2) for x in h], "hdg": [r(x[4], 1) for x in h],
                "cmd": [r(x[5], 1) for x in h],
            },
        }


class Book:
    """Every boat heard, by id; thread-safe."""

    def __init__(self, track=None, history_s=600.0, stale_s=3.0):
        self.lock = threading.Lock()
        self.boats = {}
        self.history_s = history_s
        self.stale_s = stale_s
        self.count = self.bad = 0
        self.last_error = ""
        self.track = track  # [(name, lat_e7, lon_e7)] or None
        self.frame = LocalFrame(track[0][1], track[0][2]) if track else None

    def datagram(self, data, now=None):
        now = time.monotonic() if now is None else now
        try:
            st = decode_status(data)
        except ValueError as e:
            with self.lock:
                self.bad += 1
                self.last_error = str(e)
            return None
        with self.lock:
            self.count += 1
            if self.frame is None and st.pos_valid:
                self.frame = LocalFrame(st.lat_e7, st.lon_e7)  # no track: the first position heard
            b = self.boats.get(st.boat_id)
            if b is None:
                b = self.boats[st.boat_id] = Boat(st.boat_id, self.history_s)
            b.add(st, now, self.frame)
        return st

    def to_json(self, source=""):
        now = time.monotonic()
        with self.lock:
            track = []
            if self.track and self.frame is not None:
                for i, (name, la, lo) in enumerate(self.track):
                    e, n = self.frame.en(la, lo)
                    track.append({"name": name or "WP%d" % (i + 1), "e": round(e, 2), "n": round(n, 2)})
            return {
                "source": source, "datagrams": self.count, "bad": self.bad, "last_error": self.last_error,
                "stale_s": self.stale_s, "history_s": self.history_s, "track": track,
                "boats": [self.boats[k].to_json(now, self.stale_s, self.frame) for k in sorted(self.boats)],
            }


def load_track(path):
    """[(name, lat_e7, lon_e7)] of a track file, with the firmware's parser (raises TrackError)."""
    from trackpilot.track import parse_track_csv

    t = parse_track_csv(Path(path).read_bytes())
    return [(w.name, w.lat_e7, w.lon_e7) for w in t.waypoints]


def make_handler(book, source_name):
    class Handler(BaseHTTPRequestHandler):
        server_version = "trackpilot-monitor"

        def log_message(self, fmt, *args):  # quiet: the terminal shows the link, not each request
            pass

        def _send(self, code, body, ctype):
            self.send_response(code)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(body)

        def do_GET(self):
            path = self.path.split("?", 1)[0]
            if path == "/api/state":
                body = json.dumps(book.to_json(source_name)).encode()
                return self._send(200, body, "application/json")
            if path in STATIC:
                name, ctype = STATIC[path]
                return self._send(200, (WEB_DIR / name).read_bytes(), ctype)
            return self._send(404, b"not found\n", "text/plain")

        do_HEAD = do_GET

        def _read_only(self):
            self._send(405, b"read-only monitor\n", "text/plain")

        do_POST = do_PUT = do_DELETE = do_PATCH = _read_only

    return Handler


def serve(src, book, host, port, duration_s=0.0, out=print):
    """Read `src` into `book` on a thread and serve the page until Ctrl-C (or duration_s)."""
    try:
        httpd = ThreadingHTTPServer((host, port), make_handler(book, src.name))
    except OSError as e:
        from trackpilot_tools.errors import UserError

        raise UserError("cannot serve on http://%s:%d/: %s (another monitor running? try --http-port)"
                        % (host, port, e.strerror or e))
    httpd.daemon_threads = True
    stop = threading.Event()

    def reader():
        while not stop.is_set():
            data = src.read()
            if data is not None:
                book.datagram(data)

    threading.Thread(target=reader, daemon=True).start()
    threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.2}, daemon=True).start()
    shown = "localhost" if host in ("127.0.0.1", "") else host
    out("web monitor: http://%s:%d/  (status from %s; Ctrl-C stops)" % (shown, httpd.server_address[1], src.name))
    try:
        t_end = time.monotonic() + duration_s if duration_s else None
        while t_end is None or time.monotonic() < t_end:
            time.sleep(0.2)
    finally:
        stop.set()
        httpd.shutdown()
        httpd.server_close()
    return book
