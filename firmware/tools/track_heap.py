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
        trk = track.parse_track_csv(f, budget_b=1 << 30)  # measured even past the budget
    gc.collect()
    live = gc.mem_alloc() - before
    assert len(trk.waypoints) == n
    return size, live, trk


def write_named_track(path, n, name_chars=0, radii=False, blank_every=0, lat0=514900000, lon0=36100000):
    """A valid n-waypoint line track of 6 m legs due east; every waypoint named with name_chars
    characters (0: no name column; a list: each waypoint's), an arrival radius on each when
    radii, a blank line after every blank_every-th waypoint (0: none)."""
    with open(path, "w") as f:
        f.write("lon,lat,speed_mps" + (",name" if name_chars else "") + (",radius_m" if radii else "") + "\n")
        for i in range(n):
            la, lo = geo.move_e7(lat0, lon0, 6.0 * i, 0.0)
            line = "%d.%07d,%d.%07d,1.5" % (lo // 10000000, lo % 10000000, la // 10000000, la % 10000000)
            if name_chars:
                k = name_chars if isinstance(name_chars, int) else name_chars[i]
                line += "," + ("w%d" % i + "x" * k)[:k]
            if radii:
                line += ",4.5"
            f.write(line + "\n")
            if blank_every and i % blank_every == blank_every - 1:
                f.write("\n")


def _budget_names(n, chars):
    """Name lengths for n waypoints with `chars` characters of names in all: the first waypoints
    get MAX_NAME_CHARS each, the next the rest, the others none."""
    out = []
    for i in range(n):
        out.append(max(0, min(track.MAX_NAME_CHARS, chars - i * track.MAX_NAME_CHARS)))
    return out


def _names_est(n, lens):
    per_page = [0] * ((n + track._PAGE - 1) // track._PAGE)
    for i in range(n):
        per_page[i >> track._PAGE_SHIFT] += lens[i]
    return track.track_heap_bytes(n, per_page, 1, False)


def write_budget_track(path, n, over=False, budget_b=None):
    """A line track of n waypoints whose names make its ESP32 heap (track_heap_bytes) just inside
    the budget (the most name characters that fit), or with over, one character more (the fewest
    that pass it); returns that heap figure."""
    budget_b = track.TRACK_BUDGET_B if budget_b is None else budget_b
    lo = -1  # name characters that fit (-1: not even a track without names)
    hi = n * track.MAX_NAME_CHARS + 1
    while hi - lo > 1:  # the estimate grows with the names' bytes
        mid = (lo + hi) // 2
        if _names_est(n, _budget_names(n, mid)) <= budget_b:
            lo = mid
        else:
            hi = mid
    chars = hi if over else lo
    if chars < 0 or chars > n * track.MAX_NAME_CHARS:
        raise ValueError("no track of %d waypoints is %s the budget" % (n, "over" if over else "inside"))
    lens = _budget_names(n, chars)
    write_named_track(path, n, lens)
    return _names_est(n, lens)


def measure_budget(path):
    """(estimated, measured) heap bytes of the track in path on this interpreter: parsed and
    validated (its leg cache full), as the firmware's load does."""
    word_b = 8 if sys.maxsize > (1 << 32) else 4
    float_b = 8 if track._FLOAT_CODE == "d" else 4
    with open(path, "rb") as f:
        n, name_bytes, breaks, radii = track._survey(f, budget_b=1 << 30)
    est = track.track_heap_bytes(n, name_bytes, breaks, radii, word_b, float_b)
    gc.collect()
    before = gc.mem_alloc()
    with open(path, "rb") as f:
        trk = track.parse_track_csv(f, budget_b=1 << 30)
    track.validate(trk, None)
    gc.collect()
    return est, gc.mem_alloc() - before


def main():
    if sys.argv[1:2] == ["--budget"]:  # --budget N NAME_CHARS RADII(0/1) BLANK_EVERY ...
        a = [int(x) for x in sys.argv[2:]]
        for k in range(0, len(a), 4):
            write_named_track(TMP, a[k], a[k + 1], a[k + 2] != 0, a[k + 3])
            est, live = measure_budget(TMP)
            print("BUDGET %d %d %d %d est %d live %d esp32 %d" % (
                a[k], a[k + 1], a[k + 2], a[k + 3], est, live, track_esp32_b(TMP)))
        return
    sizes = [int(a) for a in sys.argv[1:]] or [34, 500, 2000]
    print("waypoints file_B live_B B_per_wp")
    for n in sizes:
        size, live, trk = measure(n)
        print("%d %d %d %.1f" % (n, size, live, live / n))
        trk = None
        gc.collect()


def track_esp32_b(path):
    """The figure the budget limits: the estimate for the ESP32's layout."""
    with open(path, "rb") as f:
        n, name_bytes, breaks, radii = track._survey(f, budget_b=1 << 30)
    return track.track_heap_bytes(n, name_bytes, breaks, radii)


if __name__ == "__main__":
    main()
