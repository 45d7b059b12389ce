# geo.py under MicroPython: NMEA text to integers, lever arm, frames, antimeridian.
# (Accuracy against geographiclib is tests/host/test_geo_oracle.py.)
import tpassert as t
from trackpilot.nav import geo


def test_ddmm_exact():
    t.eq(geo.ddmm_to_e7("5129.4000000", "N"), 514900000)
    t.eq(geo.ddmm_to_e7(b"00336.6000000", b"E"), 36100000)
    t.eq(geo.ddmm_to_e7("00336.6", "W"), -36100000)
    t.eq(geo.ddmm_to_e7("4916.45", "S"), -492741667)  # 16.45/60 = 0.27416666..
    t.eq(geo.ddmm_to_e7("12000", "E"), 1200000000)
    t.eq(geo.ddmm_to_e7("17959.9999999", "E"), 1799999999 + 1)  # 59.9999999/60 rounds up
    t.eq(geo.ddmm_to_e7("9000.0000000", "N"), 900000000)
    t.eq(geo.ddmm_to_e7("5129.4", ord("N")), 514900000)


def test_ddmm_rounding_half_away_from_zero():
    # 0.000003 min = 0.5e-7 deg exactly: a tie, rounded away from zero on both hemispheres
    t.eq(geo.ddmm_to_e7("0000.000003", "N"), 1)
    t.eq(geo.ddmm_to_e7("0000.000003", "S"), -1)
    t.eq(geo.ddmm_to_e7("0000.0000029", "N"), 0)
    # 12 decimals and 1e-9 output
    t.eq(geo.ddmm_to_e7("5129.400000000003", "N"), 514900000)
    t.eq(geo.ddmm_to_e9("5129.4000001", "N"), 51490000000 + 2)  # 1e-7 min = 1.67e-9 deg
    t.eq(geo.split_e9(51490000002), (514900000, 2))
    t.eq(geo.split_e9(-51490000051), (-514900001, 49))


def test_ddmm_malformed():
    for bad in ("", "51.2", "5160.0", "51x9.4", "5129.4.1", "-5129.4", "5129.4 ", "9000.1"):
        t.raises(ValueError, geo.ddmm_to_e7, bad, "N")
    t.raises(ValueError, geo.ddmm_to_e7, "18000.0001", "E")
    t.raises(ValueError, geo.ddmm_to_e7, "5129.4", "X")
    t.raises(ValueError, geo.ddmm_to_e7, "5129.4", "")
    t.raises(ValueError, geo.ddmm_to_e7, "5129.4000000000000", "N")  # 13 decimals


def test_decimal_to_e7():
    t.eq(geo.decimal_to_e7("51.49"), 514900000)
    t.eq(geo.decimal_to_e7("-3.6123456"), -36123456)
    t.eq(geo.decimal_to_e7("+3.61234565"), 36123457)
    t.eq(geo.decimal_to_e7("-3.61234565"), -36123457)
    t.eq(geo.decimal_to_e7("-3.61234564999"), -36123456)
    t.eq(geo.decimal_to_e7("179.99999999"), 1800000000)
    t.eq(geo.decimal_to_e7("3"), 30000000)
    t.eq(geo.decimal_to_e7(".5"), 5000000)
    for bad in ("", "-", ".", "1e5", "3,6", "51.49.1", "nan", "12 3"):
        t.raises(ValueError, geo.decimal_to_e7, bad)


def test_frame_and_bearing_basics():
    lat, lon = 514900000, 36100000
    d, b = geo.dist_bearing(lat, lon, lat + 9000, lon)  # 0.0009 deg north = 100.1 m
    t.near(d, 100.1, 0.1)
    t.near(b, 0.0, 1e-4)
    e, n = geo.offset_m(lat, lon, lat, lon + 14000)
    t.near(n, 0.0, 0.01)  # due east: no north component beyond convergence (mm)
    t.true(e > 96.0 and e < 98.0, "east %r" % e)
    t.eq(geo.dist_bearing(lat, lon, lat, lon), (0.0, 0.0))


def test_antimeridian():
    # 0.0001 deg either side of 180 at the equator: 22.3 m apart, due east
    d, b = geo.dist_bearing(0, 1799999000, 0, -1799999000)
    t.near(d, 22.26, 0.01)
    t.near(b, 90.0, 1e-4)
    la, lo = geo.move_e7(0, 1799999000, 22.263898, 0.0)
    t.eq(la, 0)
    t.near(lo, -1799999000, 1)


def test_move_roundtrip():
    lat, lon = 514900000, 36100000
    la, lo, lah, loh = geo.move_hp(lat, lon, 123.456, -654.321)
    e, n = geo.offset_m(lat, lon, la, lo, 0, 0, lah, loh)
    t.near(e, 123.456, 0.001)
    t.near(n, -654.321, 0.001)


def test_lever_arm():
    lat, lon = 514900000, 36100000
    m_north, _ = geo.radii_m(51.49)
    # antenna 2 m ahead of the reference point, heading north: reference is 2 m south
    la, lo = geo.apply_lever_arm(lat, lon, 0.0, 2.0, 0.0)
    e, n = geo.offset_m(lat, lon, la, lo)
    t.near(e, 0.0, 0.006)
    t.near(n, -2.0, 0.006)
    # heading east, antenna 1 m to starboard (south of the reference point): reference is north
    la, lo, lah, loh = geo.apply_lever_arm_hp(lat, lon, 0, 0, 90.0, 0.0, 1.0)
    e, n = geo.offset_m(lat, lon, la, lo, 0, 0, lah, loh)
    t.near(e, 0.0, 0.001)
    t.near(n, 1.0, 0.001)
    # heading 225, 1.5 m forward + 0.5 m starboard
    la, lo, lah, loh = geo.apply_lever_arm_hp(lat, lon, 0, 0, 225.0, 1.5, 0.5)
    e, n = geo.offset_m(lat, lon, la, lo, 0, 0, lah, loh)
    t.near(e, 0.7071 * 1.5 + 0.7071 * 0.5, 0.001)
    t.near(n, 0.7071 * 1.5 - 0.7071 * 0.5, 0.001)
    t.eq(geo.apply_lever_arm(lat, lon, 77.0, 0.0, 0.0), (lat, lon))
