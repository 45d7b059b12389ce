"""The firmware geodesy (run under MicroPython, $MICROPYTHON) against geographiclib.

Thousands of random pairs up to 1 km apart, within 10 km of a start point, at latitudes
0, 51.5, 60, -45 and at longitudes beyond 107 deg (120, 179.95 and -179.95: the pairs there
straddle the antimeridian). Targets (ARCHITECTURE.md): distance error <= 1 cm, bearing error
<= 0.01 deg for pairs more than 10 m apart. The maxima are printed (run with -s) and kept in
geo.py's docstring.
"""
import math
import random
import sys
from pathlib import Path

from geographiclib.geodesic import Geodesic

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "firmware"))

from trackpilot.nav import geo  # noqa: E402  (CPython import of the same module)
from trackpilot_tools.mpy import run_script  # noqa: E402
import pytest

# runs firmware code under $MICROPYTHON: also part of the float32 pass of `make test`
pytestmark = pytest.mark.mpy

WGS = Geodesic.WGS84
HELPER = Path(__file__).with_name("_geo_mpy.py")
STARTS = [(0.0, 3.6), (51.5, 3.61), (60.0, 3.6), (-45.0, 3.6), (51.5, 120.0),
          (0.0, 179.95), (60.0, -179.95), (-45.0, 179.99)]
N_PER_START = 2000


def _e7(x):
    return int(round(x * 1e7))


def _wrap180(a):
    return (a + 180.0) % 360.0 - 180.0


def _pairs():
    rnd = random.Random(20261122)
    pairs = []
    for lat_s, lon_s in STARTS:
        for i in range(N_PER_START):
            g = WGS.Direct(lat_s, lon_s, rnd.uniform(0, 360), 10000.0 * math.sqrt(rnd.random()))
            # a few very short pairs and the rest up to 1 km
            s = rnd.uniform(0, 20.0) if i % 10 == 0 else rnd.uniform(0, 1000.0)
            h = WGS.Direct(g["lat2"], g["lon2"], rnd.uniform(0, 360), s)
            hp = [rnd.randint(-99, 99) for _ in range(4)] if i % 3 == 0 else [0, 0, 0, 0]
            pairs.append((_e7(g["lat2"]), _e7(g["lon2"]), _e7(h["lat2"]), _e7(h["lon2"]), *hp))
    return pairs


def _oracle(p):
    la0 = p[0] * 1e-7 + p[4] * 1e-9
    lo0 = p[1] * 1e-7 + p[5] * 1e-9
    la1 = p[2] * 1e-7 + p[6] * 1e-9
    lo1 = p[3] * 1e-7 + p[7] * 1e-9
    r = WGS.Inverse(la0, lo0, la1, lo1)
    return r["s12"], r["azi1"] % 360.0


def _run_mpy(lines):
    proc = run_script(HELPER, stdin_bytes=("\n".join(lines) + "\n").encode(), timeout=300)
    return [ln.split() for ln in proc.stdout.decode().splitlines() if ln.strip()]


def _errors(pairs, results):
    max_d = max_b = max_en = 0.0
    n_b = 0
    for p, r in zip(pairs, results):
        d, b, e, n = (float(x) for x in r)
        s, azi = _oracle(p)
        max_d = max(max_d, abs(d - s))
        # offset_m is (s sin azi, s cos azi) in the frame at point 0
        max_en = max(max_en, math.hypot(e - s * math.sin(math.radians(azi)),
                                        n - s * math.cos(math.radians(azi))))
        if s > 10.0:
            n_b += 1
            max_b = max(max_b, abs(_wrap180(b - azi)))
    return max_d, max_b, max_en, n_b


def test_geo_against_geographiclib_under_micropython():
    pairs = _pairs()
    res = _run_mpy(["d " + " ".join(str(v) for v in p) for p in pairs])
    assert len(res) == len(pairs)
    max_d, max_b, max_en, n_b = _errors(pairs, res)
    print("\ngeo under MicroPython: %d pairs (%d > 10 m): max distance error %.2e m, max bearing"
          " error %.2e deg, max offset_m error %.2e m" % (len(pairs), n_b, max_d, max_b, max_en))
    assert n_b > 10000
    assert max_d <= 0.01
    assert max_b <= 0.01
    assert max_en <= 0.01


def test_geo_same_under_cpython():
    pairs = _pairs()[::4]
    res = []
    for p in pairs:
        d, b = geo.dist_bearing(*p)
        e, n = geo.offset_m(*p)
        res.append((d, b, e, n))
    max_d, max_b, max_en, n_b = _errors(pairs, res)
    print("\ngeo under CPython: max distance error %.2e m, bearing %.2e deg" % (max_d, max_b))
    assert max_d <= 0.01 and max_b <= 0.01 and max_en <= 0.01


def test_move_hp_inverts_against_geographiclib():
    rnd = random.Random(7)
    lines, cases = [], []
    for lat_s, lon_s in STARTS:
        for _ in range(150):
            lat_e7, lon_e7 = _e7(lat_s + rnd.uniform(-0.05, 0.05)), _e7(lon_s + rnd.uniform(-0.05, 0.05))
            s, azi = rnd.uniform(0, 1000.0), rnd.uniform(0, 360)
            e, n = s * math.sin(math.radians(azi)), s * math.cos(math.radians(azi))
            lines.append("m %d %d %.6f %.6f" % (lat_e7, lon_e7, e, n))
            g = WGS.Direct(lat_e7 * 1e-7, lon_e7 * 1e-7, azi, s)
            cases.append((g["lat2"], g["lon2"]))
    res = _run_mpy(lines)
    worst = 0.0
    for (lat, lon), r in zip(cases, res):
        la, lo, lah, loh = (int(x) for x in r)
        assert -50 <= lah <= 49 and -50 <= loh <= 49
        got = WGS.Inverse(lat, lon, la * 1e-7 + lah * 1e-9, lo * 1e-7 + loh * 1e-9)["s12"]
        worst = max(worst, got)
    print("\nmove_hp: max position error %.2e m over %d moves up to 1 km" % (worst, len(res)))
    assert worst <= 0.005


def test_seed_formulas_are_only_a_comparison():
    """The seed's sphere (R = 6377918 m) misses the 1 cm target by far: measured, not assumed."""
    pairs = [p for p in _pairs()[::8] if p[4:] == (0, 0, 0, 0)]
    res = _run_mpy(["s %d %d %d %d" % p[:4] for p in pairs])
    worst_rel = 0.0
    for p, r in zip(pairs, res):
        s, _ = _oracle(p)
        if s > 100.0:
            worst_rel = max(worst_rel, abs(float(r[0]) - s) / s)
    print("\nseed spherical formulas: max relative distance error %.2e" % worst_rel)
    assert worst_rel > 1e-3  # > 1 m per km: why the project does not use them
