# Prints RMB and APB for boat positions on a track, under MicroPython.
# stdin: the track CSV, a line "--", then "leg lat_e7 lon_e7 sog_mps cog_deg auto" per case.
import sys
from trackpilot.fix import Fix
from trackpilot import nmea_out
from trackpilot.progress import Progress
from trackpilot.track import parse_track_csv

text = sys.stdin.read()
csv_text, _, cases = text.partition("--\n")
track = parse_track_csv(csv_text)
for line in cases.split("\n"):
    if not line.strip():
        continue
    leg, la, lo, sog, cog, auto = line.split()
    p = Progress(track)
    p.set_leg(int(leg))
    f = Fix()
    f.pos_valid = True
    f.vel_valid = True
    f.lat_e7 = int(la)
    f.lon_e7 = int(lo)
    f.sog_mps = float(sog)
    f.cog_deg = float(cog)
    p.update(f.lat_e7, f.lon_e7)
    out = nmea_out.route(f, p, valid=auto == "1", heading_cmd_deg=123.4 if auto == "1" else None)
    sys.stdout.write("%d %.3f %s" % (p.leg, p.xte_m, out.decode().replace("\r\n", " ")) + "\n")
