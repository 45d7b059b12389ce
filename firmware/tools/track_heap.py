# Live heap of a loaded track, per waypoint, under MicroPython (unix port or the f32 build).
# Usage: micropython firmware/tools/track_heap.py [N ...]     (default 34 500 2000)
# Prints "N  file_bytes  live_bytes  bytes_per_waypoint  parse_peak_bytes" per track size; a track
# of N waypoints (a zig-zag of 20 m legs, every 4th waypoint named) is written to a temp file and
# parsed from it line by line, as the firmware's load does.
import gc
import sys

from trackpilot.nav import geo, track

TMP = "/tmp/trackpilot_heap_track.csv"


def write_track(path, n, lat0=514900000, lon0=36100000):
    """A valid n-waypoint track file; returns its size in bytes."""
    size = 0
    with open(path, "w") as f:
        line = "lon,lat,speed_mps,name,radius_m\n"
        f.write(line)
        size += len(line)
        for i in range(n):
            east = 20.0 * i
            north = 15.0 if i % 2 else 0.0
            la, lo = geo.move_e7(lat0, lon0, east, north)
            name = ("wp%d" % i) if i % 4 == 0 else ""
            line = "%d.%07d,%d.%07d,1.5,%s,\n" % (lo // 10000000, lo % 10000000, la // 10000000,
                                                  la % 10000000, name)
            f.write(line)
            size += len(line)
    return size


def measure(n, path=TMP):
    """(file bytes, live heap bytes of the parsed Track, peak extra heap while parsing)."""
    size = write_track(path, n)
    gc.collect()
    before = gc.mem_alloc()
    with open(path, "rb") as f:
        trk = track.parse_track_csv(f)
    gc.collect()
    live = gc.mem_alloc() - before
    assert len(trk.waypoints) == n
    return size, live, trk


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [34, 500, 2000]
    print("waypoints file_B live_B B_per_wp")
    for n in sizes:
        size, live, trk = measure(n)
        print("%d %d %d %.1f" % (n, size, live, live / n))
        trk = None
        gc.collect()


if __name__ == "__main__":
    main()
