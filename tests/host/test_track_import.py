"""track import: GPX routes/tracks (OpenCPN), KML/KMZ (Google My Maps), CSV -> validated tracks."""
import argparse
import math
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "firmware"))

from trackpilot.nav import track as fw_track  # noqa: E402
from trackpilot_tools import track_import as TI  # noqa: E402

DATA = ROOT / "tests" / "data" / "import"
# The same four points in every fixture (1e-7 deg; the GPX has 8-9 decimals, rounded half away).
LOOP = [(514949981, 36100023), (514958523, 36114117), (514956339, 36126142), (514949001, 36122999)]


def _wps(text):
    return [(w.lat_e7, w.lon_e7) for w in fw_track.parse_track_csv(text).waypoints]


def test_opencpn_gpx_route():
    text, trk, warnings = TI.import_track(DATA / "opencpn_route.gpx", speed_mps=2.0)
    assert _wps(text) == LOOP
    assert [w.name for w in trk.waypoints] == ["001", "002", "bridge", "004"]
    assert all(abs(w.speed_mps - 2.0) < 1e-9 for w in trk.waypoints)
    assert isinstance(warnings, list)


def test_google_my_maps_kml_line_and_kmz(tmp_path):
    text, trk, _ = TI.import_track(DATA / "mymaps.kml", leg_speeds=[2, 1.5, 0.5])
    assert _wps(text) == LOOP
    assert [round(w.speed_mps, 3) for w in trk.waypoints[:3]] == [2.0, 1.5, 0.5]
    kmz = tmp_path / "mymaps.kmz"
    with zipfile.ZipFile(kmz, "w") as z:
        z.write(DATA / "mymaps.kml", "doc.kml")
    assert _wps(TI.import_track(kmz)[0]) == LOOP


def test_kml_points_only(tmp_path):
    src = (DATA / "mymaps.kml").read_text()
    start = src.index("<Placemark>\n        <name>Canal loop")
    end = src.index("</Placemark>", start) + len("</Placemark>")
    p = tmp_path / "points.kml"
    p.write_text(src[:start] + src[end:])
    text, trk, _ = TI.import_track(p)
    assert _wps(text) == [LOOP[0], LOOP[2]]
    assert [w.name for w in trk.waypoints] == ["Start quay", "Bridge"]


def test_csv_with_knots_column():
    text, trk, _ = TI.import_track(DATA / "points_kn.csv", speed_mps=1.0)
    assert _wps(text) == LOOP
    kn = 1852 / 3600
    assert [round(w.speed_mps, 3) for w in trk.waypoints] == [round(4 * kn, 3), round(2 * kn, 3),
                                                              round(1 * kn, 3), 1.0]


def _recorded_gpx(path, n_per_leg=120):
    """A recorded L-shaped track: points every ~1 m with 0.2 m jitter."""
    pts = []
    lat0, lon0 = 514950000, 36100000
    for i in range(n_per_leg):  # 120 m north
        pts.append((lat0 + round(i * 1.0 / 0.0111195) + (i % 3 - 1) * 15, lon0 + (i % 2) * 20))
    for i in range(1, n_per_leg):  # then 120 m east
        pts.append((pts[n_per_leg - 1][0] + (i % 2) * 15,
                    lon0 + round(i * 1.0 / (0.0111195 * math.cos(math.radians(51.495))))))
    body = "\n".join('<trkpt lat="%s" lon="%s"><ele>0</ele></trkpt>'
                     % (TI._deg_text(a), TI._deg_text(b)) for a, b in pts)
    path.write_text('<?xml version="1.0"?><gpx version="1.1" creator="phone" '
                    'xmlns="http://www.topografix.com/GPX/1/1"><trk><name>recorded</name>'
                    "<trkseg>%s</trkseg></trk></gpx>" % body)
    return pts


def test_recorded_gpx_track_is_simplified(tmp_path):
    p = tmp_path / "rec.gpx"
    pts = _recorded_gpx(p)
    text, trk, _ = TI.import_track(p)
    got = _wps(text)
    assert 3 <= len(got) <= 6, got  # an L: start, corner, end (plus a few jitter points)
    assert got[0] == pts[0] and got[-1] == pts[-1]  # the ends stay exactly where recorded
    assert all(leg.length_m >= fw_track.MIN_LEG_M for leg in trk.legs)


def test_bad_inputs_give_clear_errors(tmp_path):
    bad = tmp_path / "bad.gpx"
    bad.write_text("<gpx><rte><rtept lat='51.x' lon='3.6'/></rte></gpx>")
    with pytest.raises(TI.TrackImportError, match="latitude '51.x'"):
        TI.import_track(bad)
    bad.write_text("<gpx><rte>")
    with pytest.raises(TI.TrackImportError, match="not well-formed"):
        TI.import_track(bad)
    two = tmp_path / "two.gpx"
    two.write_text("<gpx><rte><name>a</name><rtept lat='51.49' lon='3.61'/><rtept lat='51.491' lon='3.61'/></rte>"
                   "<rte><name>b</name><rtept lat='51.49' lon='3.61'/><rtept lat='51.492' lon='3.61'/></rte></gpx>")
    with pytest.raises(TI.TrackImportError, match="--select"):
        TI.import_track(two)
    assert len(_wps(TI.import_track(two, select="b")[0])) == 2
    assert _wps(TI.import_track(two, select="1")[0])[1] == (514910000, 36100000)
    with pytest.raises(TI.TrackImportError, match="3 legs"):
        TI.import_track(DATA / "mymaps.kml", leg_speeds=[1, 2])
    close = tmp_path / "close.csv"
    close.write_text("lat,lon\n51.49,3.61\n51.49001,3.61\n51.491,3.61\n")
    with pytest.raises(TI.TrackImportError, match="--simplify"):
        TI.import_track(close)
    shp = tmp_path / "x.shp"
    shp.write_bytes(b"\0" * 100)
    with pytest.raises(TI.TrackImportError, match="unknown format"):
        TI.import_track(shp)
    with pytest.raises(TI.TrackImportError, match="cannot read"):
        TI.import_track(tmp_path / "missing.gpx")


def test_cli_writes_a_file_the_firmware_loads(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    TI.add_import_parser(parser.add_subparsers())
    out = tmp_path / "canal.csv"
    args = parser.parse_args(["import", str(DATA / "opencpn_route.gpx"), "-o", str(out), "--speed-kn", "3"])
    assert args.func(args) == 0
    assert "4 waypoints" in capsys.readouterr().out
    trk = fw_track.parse_track_csv(out.read_text())
    assert abs(trk.waypoints[0].speed_mps - 3 * 1852 / 3600) < 0.001
    assert args.func(args) == 1  # exists: not replaced without --force
    assert "--force" in capsys.readouterr().err
    for bad in ("nan", "-1"):  # NaN was taken and wrote the file
        args = parser.parse_args(["import", str(DATA / "opencpn_route.gpx"), "-o", str(tmp_path / "x.csv"),
                                  "--simplify", bad])
        assert args.func(args) == 1
        assert "--simplify must be" in capsys.readouterr().err
        assert not (tmp_path / "x.csv").exists()


def test_kmz_bomb_is_refused_without_unpacking_it(tmp_path):
    """Issue 14.15: a 300 KB KMZ unpacking to 300 MB took 945 MB of RAM. The .kml is read at most
    KMZ_MAX_UNZIPPED_BYTES (+1) far: a clear error, memory bounded by the cap."""
    import tracemalloc

    bomb = tmp_path / "bomb.kmz"
    pad = b"<!--" + b" " * (1024 * 1024) + b"-->\n"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("doc.kml", "w") as f:
            f.write(b'<?xml version="1.0"?><kml xmlns="http://www.opengis.net/kml/2.2">')
            for _ in range(40):  # 40 MB unpacked
                f.write(pad)
            f.write(b"</kml>")
    assert bomb.stat().st_size < 200_000
    tracemalloc.start()
    try:
        with pytest.raises(TI.TrackImportError, match="unpacks to more than 16 MB"):
            TI.import_track(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 3 * TI.KMZ_MAX_UNZIPPED_BYTES, peak
