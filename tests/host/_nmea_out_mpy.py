# Prints NMEA sentences for fixes given on stdin: "lat_e7 lon_e7 rtk heading_deg xte_m" per line.
import sys
from trackpilot.nav.fix import Fix
from trackpilot.devices import nmea_out

for line in sys.stdin.read().split("\n"):
    if not line.strip():
        continue
    la, lo, rtk, hd, x = line.split()
    f = Fix()
    f.pos_valid = True
    f.lat_e7 = int(la)
    f.lon_e7 = int(lo)
    f.rtk = int(rtk)
    f.heading_valid = True
    f.heading_deg = float(hd)
    f.utc_s = 45296
    f.date = 221126
    f.num_sv = 17
    f.h_acc_m = 0.014
    f.sog_mps = 1.5
    f.cog_deg = 12.5
    for s in (nmea_out.gga(f), nmea_out.rmc(f), nmea_out.hdt(f), nmea_out.xte(float(x))):
        sys.stdout.write(s.decode())
