# Helper run under MicroPython by test_geo_oracle.py: reads one request a line from stdin and
# prints the firmware geo module's answer, so the oracle test also covers float32 builds.
# "d lat0 lon0 lat1 lon1 hp0a hp0o hp1a hp1o" -> "dist_m bearing_deg east_m north_m"
# "m lat lon east north"                      -> "lat_e7 lon_e7 lat_hp lon_hp"
# "s lat0 lon0 lat1 lon1"                     -> seed formulas "dist_m bearing_deg"
import sys

from trackpilot.nav import geo


def main():
    out = []
    for line in sys.stdin:
        f = line.split()
        if not f:
            continue
        if f[0] == "d":
            a = [int(x) for x in f[1:]]
            d, b = geo.dist_bearing(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7])
            e, n = geo.offset_m(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7])
            out.append("%.6f %.7f %.6f %.6f" % (d, b, e, n))
        elif f[0] == "m":
            r = geo.move_hp(int(f[1]), int(f[2]), float(f[3]), float(f[4]))
            out.append("%d %d %d %d" % r)
        elif f[0] == "s":
            a = [int(x) for x in f[1:]]
            d, b = geo.seed_dist_bearing(a[0], a[1], a[2], a[3])
            out.append("%.6f %.7f" % (d, b))
        if len(out) >= 200:
            print("\n".join(out))
            out = []
    if out:
        print("\n".join(out))


main()
