"""Import a route from GPX (OpenCPN and other chart tools), KML/KMZ (Google My Maps) or CSV into a
validated trackpilot track file (tracks/README.md).

Coordinates are converted from their text to 1e-7 deg integers without a float
(trackpilot.nav.geo.decimal_to_e7), so an imported point is exactly the point in the file.
Speeds: a default (--speed / --speed-kn), a list per leg (--leg-speeds), or a column of the
CSV (speed_mps or speed_kn), in that order of precedence: per leg > column > default.
Recorded GPX tracks (dense points) are simplified (Douglas-Peucker, --simplify metres) and points
closer than the shortest steerable leg are merged; routes and placemarks are kept as drawn.
The result is parsed and validated by the firmware's own track module before it is written.

Usage:
    trackpilot track import route.gpx -o tracks/canal.csv --speed-kn 3
    trackpilot track import mymap.kml --select "Canal loop" --leg-speeds 2,2,1,0.5
    from trackpilot_tools.track_import import import_track
    text, trk, warnings = import_track("route.gpx", speed_mps=1.5)
"""
import csv
import io
import os
import sys
import xml.etree.ElementTree as ET
import zipfile

from trackpilot_tools.mpy import FIRMWARE_DIR

if str(FIRMWARE_DIR) not in sys.path:
    sys.path.insert(0, str(FIRMWARE_DIR))

from trackpilot.nav import geo  # noqa: E402
from trackpilot.nav import track as fw_track  # noqa: E402

KNOT_MPS = 1852.0 / 3600.0
DEFAULT_SPEED_MPS = 1.5
TRACK_SIMPLIFY_M = 2.0  # default tolerance for recorded GPX tracks
# The .kml inside a KMZ is read at most this big: a 2000-waypoint route is well under 1 MB and a
# long recorded track a few MB, while a 300 KB zip bomb can unpack to hundreds of MB.
KMZ_MAX_UNZIPPED_BYTES = 16 * 1024 * 1024


class TrackImportError(ValueError):
    """The input cannot become a track; the message says why and what to do."""


class Point:
    def __init__(self, lat_e7, lon_e7, name="", speed_mps=None, radius_m=None):
        self.lat_e7 = lat_e7
        self.lon_e7 = lon_e7
        self.name = name
        self.speed_mps = speed_mps
        self.radius_m = radius_m


def _e7(text, what):
    try:
        v = geo.decimal_to_e7(text.strip())
    except ValueError:
        raise TrackImportError("%s '%s' is not decimal degrees" % (what, text))
    limit = 900000000 if what == "latitude" else 1800000000
    if not -limit <= v <= limit:
        raise TrackImportError("%s %s is out of range" % (what, text))
    return v


def _local(tag):
    return tag.rsplit("}", 1)[-1]


def _child_text(el, name):
    for c in el:
        if _local(c.tag) == name:
            return (c.text or "").strip()
    return ""


def _choose(candidates, select, kind):
    """candidates: [(name, points)]. select: None, a name or a 1-based index."""
    if not candidates:
        raise TrackImportError("no %s found" % kind)
    if select is None:
        if len(candidates) == 1:
            return candidates[0]
        names = ", ".join("%d: '%s' (%d points)" % (i + 1, n, len(p))
                          for i, (n, p) in enumerate(candidates))
        raise TrackImportError("%d %ss in the file (%s): choose one with --select NAME or NUMBER"
                               % (len(candidates), kind, names))
    for n, p in candidates:
        if n == select:
            return n, p
    if str(select).isdigit() and 1 <= int(select) <= len(candidates):
        return candidates[int(select) - 1]
    raise TrackImportError("no %s named '%s' (have: %s)"
                           % (kind, select, ", ".join("'%s'" % n for n, _ in candidates)))


def _parse_xml(data):
    try:
        return ET.fromstring(data)
    except ET.ParseError as e:
        raise TrackImportError("not well-formed XML: %s" % e)


def read_gpx(data, select=None):
    """-> (name, points, kind) with kind 'route', 'track' or 'waypoints'."""
    root = _parse_xml(data)
    if _local(root.tag) != "gpx":
        raise TrackImportError("not a GPX file (root element <%s>)" % _local(root.tag))

    def pt(el):
        return Point(_e7(el.get("lat", ""), "latitude"), _e7(el.get("lon", ""), "longitude"),
                     _child_text(el, "name"))

    routes = []
    tracks = []
    wpts = []
    for el in root:
        tag = _local(el.tag)
        if tag == "rte":
            routes.append((_child_text(el, "name") or "route %d" % (len(routes) + 1),
                           [pt(p) for p in el if _local(p.tag) == "rtept"]))
        elif tag == "trk":
            pts = []
            for seg in el:
                if _local(seg.tag) == "trkseg":
                    pts += [pt(p) for p in seg if _local(p.tag) == "trkpt"]
            tracks.append((_child_text(el, "name") or "track %d" % (len(tracks) + 1), pts))
        elif tag == "wpt":
            wpts.append(pt(el))
    if routes or tracks:
        cands = [(n, p, "route") for n, p in routes] + [(n, p, "track") for n, p in tracks]
        if select is None and len(routes) == 1:
            return cands[0]
        if select is None and not routes and len(tracks) == 1:
            return cands[0]
        kinds = {n: k for n, _, k in cands}
        name, pts = _choose([(n, p) for n, p, _ in cands], select, "route or track")
        return name, pts, kinds[name] if select is None or not str(select).isdigit() else \
            cands[int(select) - 1][2]
    if wpts:
        return "waypoints", wpts, "waypoints"
    raise TrackImportError("the GPX file has no route, track or waypoints")


def read_kml(data, select=None):
    """Google My Maps and Google Earth KML (or KMZ bytes). A line placemark is the route; without
    one, the point placemarks in document order are the waypoints."""
    if data[:2] == b"PK":
        try:
            with zipfile.ZipFile(io.BytesIO(data)) as z:
                names = [n for n in z.namelist() if n.lower().endswith(".kml")]
                if not names:
                    raise TrackImportError("KMZ without a .kml inside")
                name = "doc.kml" if "doc.kml" in names else names[0]
                with z.open(name) as f:  # bounded: never trust the sizes the zip declares
                    data = f.read(KMZ_MAX_UNZIPPED_BYTES + 1)
                if len(data) > KMZ_MAX_UNZIPPED_BYTES:
                    raise TrackImportError("KMZ: %s unpacks to more than %d MB; a route is far smaller "
                                           "(export the route alone, or unzip it and import the .kml)"
                                           % (name, KMZ_MAX_UNZIPPED_BYTES // (1024 * 1024)))
        except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, EOFError, OSError) as e:
            raise TrackImportError("bad KMZ: %s" % e)
    root = _parse_xml(data)
    if _local(root.tag) != "kml":
        raise TrackImportError("not a KML file (root element <%s>)" % _local(root.tag))
    lines = []
    points = []
    for pm in root.iter():
        if _local(pm.tag) != "Placemark":
            continue
        name = _child_text(pm, "name")
        for geom in pm.iter():
            tag = _local(geom.tag)
            if tag in ("LineString", "Point"):
                coords = _child_text(geom, "coordinates").split()
                pts = []
                for c in coords:
                    f = c.split(",")
                    if len(f) < 2:
                        raise TrackImportError("bad KML coordinate '%s' in '%s'" % (c, name))
                    pts.append(Point(_e7(f[1], "latitude"), _e7(f[0], "longitude")))
                if tag == "LineString":
                    lines.append((name or "line %d" % (len(lines) + 1), pts))
                elif pts:
                    pts[0].name = name
                    points.append(pts[0])
    if lines:
        return _choose(lines, select, "line") + ("route",)
    if len(points) >= 2:
        return "points", points, "waypoints"
    raise TrackImportError("the KML file has no line and fewer than 2 points")


_LAT = ("lat", "latitude")
_LON = ("lon", "lng", "long", "longitude")


def read_csv(text):
    """CSV with a header: lat/latitude, lon/lng/longitude, optional name, speed_mps or speed_kn,
    radius_m. Comma, semicolon or tab separated; '#' comment lines are skipped."""
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise TrackImportError("empty CSV")
    head = lines[0]
    delim = "\t" if "\t" in head else (";" if ";" in head and "," not in head else ",")
    rows = list(csv.reader(lines, delimiter=delim))
    cols = [c.strip().lower().lstrip("\ufeff") for c in rows[0]]

    def find(names):
        for n in names:
            if n in cols:
                return cols.index(n)
        return None

    ilat, ilon = find(_LAT), find(_LON)
    if ilat is None or ilon is None:
        raise TrackImportError("the CSV header needs lat and lon columns (have: %s)" % ", ".join(cols))
    iname, imps, ikn, irad = find(("name",)), find(("speed_mps",)), find(("speed_kn", "speed_kts")), find(("radius_m",))
    pts = []
    for n, row in enumerate(rows[1:], 2):
        if len(row) <= max(ilat, ilon):
            raise TrackImportError("CSV line %d: too few fields" % n)
        p = Point(_e7(row[ilat], "latitude"), _e7(row[ilon], "longitude"))
        if iname is not None and iname < len(row):
            p.name = row[iname].strip()
        try:
            if imps is not None and imps < len(row) and row[imps].strip():
                p.speed_mps = float(row[imps])
            elif ikn is not None and ikn < len(row) and row[ikn].strip():
                p.speed_mps = float(row[ikn]) * KNOT_MPS
            if irad is not None and irad < len(row) and row[irad].strip():
                p.radius_m = float(row[irad])
        except ValueError:
            raise TrackImportError("CSV line %d: a speed or radius is not a number" % n)
        pts.append(p)
    return "csv", pts, "route"


def _dist_m(a, b):
    return geo.dist_bearing(a.lat_e7, a.lon_e7, b.lat_e7, b.lon_e7)[0]


def _off_line_m(p, a, b):
    """Distance of p from the segment a-b (local frame at a)."""
    bx, by = geo.offset_m(a.lat_e7, a.lon_e7, b.lat_e7, b.lon_e7)
    px, py = geo.offset_m(a.lat_e7, a.lon_e7, p.lat_e7, p.lon_e7)
    ll = bx * bx + by * by
    t = 0.0 if ll == 0 else max(0.0, min(1.0, (px * bx + py * by) / ll))
    dx, dy = px - t * bx, py - t * by
    return (dx * dx + dy * dy) ** 0.5


def simplify(points, tol_m, min_leg_m):
    """Douglas-Peucker with tolerance tol_m (0: keep all), then merge points closer than
    min_leg_m to the previous kept one (0: none). Named points survive simplification."""
    pts = [p for i, p in enumerate(points)
           if i == 0 or (p.lat_e7, p.lon_e7) != (points[i - 1].lat_e7, points[i - 1].lon_e7)]
    if tol_m > 0 and len(pts) > 2:
        keep = [False] * len(pts)
        keep[0] = keep[-1] = True
        stack = [(0, len(pts) - 1)]
        while stack:
            i, j = stack.pop()
            best, k_best = -1.0, -1
            for k in range(i + 1, j):
                d = _off_line_m(pts[k], pts[i], pts[j])
                if d > best:
                    best, k_best = d, k
            if k_best >= 0 and best > tol_m:
                keep[k_best] = True
                stack += [(i, k_best), (k_best, j)]
        pts = [p for k, p in enumerate(pts) if keep[k] or pts[k].name]
    if min_leg_m > 0 and len(pts) > 2:
        out = [pts[0]]
        for p in pts[1:-1]:
            if _dist_m(out[-1], p) >= min_leg_m:
                out.append(p)
        last = pts[-1]
        while len(out) > 1 and _dist_m(out[-1], last) < min_leg_m:
            out.pop()  # the end point stays exactly where it was drawn
        out.append(last)
        pts = out
    return pts


def assign_speeds(points, default_mps=DEFAULT_SPEED_MPS, leg_speeds=None):
    """Per-leg list > the points' own (column) speeds > the default. leg_speeds has one value per
    leg (len(points) - 1), or one per point."""
    n = len(points)
    if leg_speeds is not None:
        if len(leg_speeds) not in (n - 1, n):
            raise TrackImportError("--leg-speeds has %d values; the track has %d legs"
                                   % (len(leg_speeds), n - 1))
        for i, p in enumerate(points[: len(leg_speeds)]):
            p.speed_mps = leg_speeds[i]
    for p in points:
        if p.speed_mps is None:
            p.speed_mps = default_mps
    return points


def _deg_text(v_e7):
    sign = "-" if v_e7 < 0 else ""
    v = abs(v_e7)
    return "%s%d.%07d" % (sign, v // 10000000, v % 10000000)


def to_track_csv(points, source=""):
    out = ["# imported by trackpilot track import%s" % (" from " + source if source else ""),
           "lon,lat,speed_mps,name,radius_m"]
    for p in points:
        name = (p.name or "").replace(",", " ").replace("#", " ").strip()
        name = name[: fw_track.MAX_NAME_CHARS].strip()  # the most a track takes (the display's width)
        rad = "" if p.radius_m is None else "%g" % p.radius_m
        out.append("%s,%s,%.3f,%s,%s" % (_deg_text(p.lon_e7), _deg_text(p.lat_e7), p.speed_mps,
                                         name, rad))
    return "\n".join(out) + "\n"


def read_points(path, select=None, fmt=None):
    """-> (name, points, kind) from a GPX, KML/KMZ or CSV file (format from the extension)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise TrackImportError("cannot read %s: %s" % (path, e.strerror or e))
    ext = (fmt or os.path.splitext(str(path))[1].lstrip(".")).lower()
    if ext == "gpx":
        return read_gpx(data, select)
    if ext in ("kml", "kmz"):
        return read_kml(data, select)
    if ext in ("csv", "txt"):
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise TrackImportError("%s is not UTF-8 text" % path)
        return read_csv(text)
    raise TrackImportError("unknown format '%s': use .gpx, .kml, .kmz or .csv (or --format)" % ext)


def import_track(path, speed_mps=DEFAULT_SPEED_MPS, leg_speeds=None, select=None, fmt=None,
                 simplify_m=None, min_leg_m=fw_track.MIN_LEG_M, reverse=False, boat=None):
    """-> (track CSV text, fw Track, warnings). Raises TrackImportError."""
    name, pts, kind = read_points(path, select, fmt)
    if reverse:
        pts = pts[::-1]
    if simplify_m is None:
        simplify_m = TRACK_SIMPLIFY_M if kind == "track" else 0.0
    merge_m = min_leg_m if kind == "track" or simplify_m > 0 else 0.0
    pts = simplify(pts, simplify_m, merge_m)
    if len(pts) < 2:
        raise TrackImportError("'%s' has fewer than 2 distinct points" % name)
    assign_speeds(pts, speed_mps, leg_speeds)
    text = to_track_csv(pts, "%s (%s '%s')" % (os.path.basename(str(path)), kind, name))
    try:
        trk = fw_track.parse_track_csv(text, min_leg_m=min_leg_m)
    except fw_track.TrackError as e:
        hint = ""
        if "shorter" in str(e):
            hint = " (try --simplify 1 to merge close points)"
        raise TrackImportError("the imported track is not valid: %s%s" % (e, hint))
    return text, trk, fw_track.validate(trk, boat or fw_track.BOAT_DEFAULTS)


def _speeds(text):
    try:
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise TrackImportError("--leg-speeds must be numbers separated by commas: %s" % text)


def cmd_import(args):
    try:
        if args.simplify is not None and not 0.0 <= args.simplify <= 1000.0:  # also false for NaN
            raise TrackImportError("--simplify must be a tolerance in metres, 0 to 1000")
        speed = args.speed_kn * KNOT_MPS if args.speed_kn is not None else args.speed
        legs = _speeds(args.leg_speeds) if args.leg_speeds else None
        text, trk, warnings = import_track(
            args.file, speed_mps=speed, leg_speeds=legs, select=args.select, fmt=args.format,
            simplify_m=args.simplify, reverse=args.reverse)
    except TrackImportError as e:
        sys.stderr.write("%s: %s\n" % (args.file, e))
        return 1
    out = args.output or os.path.splitext(os.path.basename(str(args.file)))[0] + ".csv"
    if os.path.abspath(out) == os.path.abspath(str(args.file)):
        sys.stderr.write("%s: refusing to overwrite the input; give -o\n" % out)
        return 1
    if os.path.exists(out) and not args.force:
        sys.stderr.write("%s exists; use --force to replace it\n" % out)
        return 1
    tmp = out + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, out)
    print("wrote %s: %d waypoints, %.1f m, about %.0f s at the legs' speeds"
          % (out, len(trk.waypoints), trk.length_m, trk.duration_s()))
    for w in warnings:
        print("warning: " + w)
    return 0


def add_import_parser(sub):
    """Add `import` to the `track` command's subparsers (called from track_cmd.add_parser)."""
    c = sub.add_parser("import", help="GPX/KML/CSV -> a validated track file")
    c.add_argument("file", help="route file: .gpx (routes, tracks), .kml/.kmz, .csv")
    c.add_argument("-o", "--output", help="track CSV to write (default: NAME.csv here)")
    c.add_argument("--force", action="store_true", help="replace the output file")
    c.add_argument("--speed", type=float, default=DEFAULT_SPEED_MPS,
                   help="speed for legs without one, m/s (default %(default)s)")
    c.add_argument("--speed-kn", type=float, help="the same in knots")
    c.add_argument("--leg-speeds", help="speeds per leg, m/s, comma separated")
    c.add_argument("--select", help="route/track/line to import, by name or number")
    c.add_argument("--format", choices=("gpx", "kml", "kmz", "csv"), help="override the extension")
    c.add_argument("--simplify", type=float, default=None,
                   help="Douglas-Peucker tolerance, m (default %g for GPX tracks, else 0)"
                   % TRACK_SIMPLIFY_M)
    c.add_argument("--reverse", action="store_true", help="sail the route backwards")
    c.set_defaults(func=cmd_import)
    return c
