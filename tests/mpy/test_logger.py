# The logger on the MicroPython os module (real files in a temporary directory): sessions,
# rotation, timed flush, deletion of the oldest session, degradation when flash is full.
import gc
import os

import tpassert as T
from trackpilot.record import logfmt as L
from trackpilot.record.logger import Logger


def _tmpdir():
    d = "/tmp/tp_logger_%s" % "".join("%02x" % b for b in os.urandom(6))
    os.mkdir(d)
    return d


def _rmtree(d):
    for name in os.listdir(d):
        os.remove(d + "/" + name)
    os.rmdir(d)


def _size(path):
    return os.stat(path)[6]


def _rec(k):
    r = L.ControlRecord()
    r.t_ms = 1000 + 200 * k
    r.lat_e7 = 514950000 + 20 * k
    r.lon_e7 = 36100000 + 13 * k
    r.lat_hp = (k * 7) % 199 - 99
    r.heading_deg = (10.0 + 0.3 * k) % 360.0
    r.sog_mps = 1.8
    r.rpm = 700 + k % 5
    return r


def _decode_dir(d, keep_controls=True):
    # keep_controls=False: thousands of decoded records would not fit a small heap
    out = []
    for name in sorted(os.listdir(d)):
        with open(d + "/" + name, "rb") as f:
            recs = [r for r in L.iter_records(f.read()) if keep_controls or r.type != "control"]
        out.append((name, recs))
        gc.collect()
    return out


def test_session_rotation_and_flush():
    d = _tmpdir()
    try:
        lg = Logger(d, fw_version="t", max_file_bytes=2500, key_every=10)
        lg.start(1000, reset_cause="power_on", config_hash="h", track_id="loop")
        T.eq(lg.path, d + "/0001-00.tpl")
        for k in range(300):
            lg.control(_rec(k))
            if k == 50:
                lg.event("MODE", "STANDBY->AUTO: test", 1000 + 200 * k)
            lg.tick(1000 + 200 * k)
        # Not closed (power loss): everything up to the last flush (<= 1 s ago) is on flash.
        files = _decode_dir(d)
        T.true(len(files) >= 4, "rotated: %d files" % len(files))
        n = 0
        for name, recs in files:
            T.true(_size(d + "/" + name) <= 2500, "part bounded")
            T.eq(recs[0].type, "header")
            T.eq(recs[0].get("session"), "1")
            T.eq(len([r for r in recs if r.type == "damage"]), 0)
            ctl = [r for r in recs if r.type == "control"]
            T.true(ctl[0].key, "each part starts with a keyframe")
            for r in ctl:
                T.eq(r.lat_e7, 514950000 + 20 * n)
                n += 1
        T.true(n >= 295, "at most 1 s (5 records) lost: %d" % n)
        # Next boot: a new session, named after the last one.
        lg2 = Logger(d, fw_version="t")
        lg2.start(0, reset_cause="watchdog")
        T.eq(lg2.session, 2)
        lg2.close()
    finally:
        _rmtree(d)


def test_full_flash_degrades_and_deletes_oldest():
    d = _tmpdir()
    try:
        quota = [40000]

        def free():
            used = 0
            for name in os.listdir(d):
                used += _size(d + "/" + name)
            return quota[0] - used

        for s in (1, 2):  # two old sessions
            with open(d + "/%04d-00.tpl" % s, "wb") as f:
                f.write(b"\0" * 10000)
        lg = Logger(d, free_fn=free, max_file_bytes=8000, low_water_bytes=30000,
                    control_reserve_bytes=20000, event_reserve_bytes=5000, space_check_ms=1000)
        lg.start(0)
        T.eq(lg.session, 3)
        for k in range(2000):
            lg.control(_rec(k))
            if k % 100 == 0:
                lg.event("INFO", "event %d" % k, 200 * k)
            lg.tick(200 * k)
        lg.close()
        names = os.listdir(d)
        T.true("0001-00.tpl" not in names and "0002-00.tpl" not in names, "old sessions deleted")
        T.true(lg.deleted_files == 2)
        T.true(lg.dropped_control > 0, "control records dropped when full")
        T.true(free() >= 0)
        evs = []
        for name, recs in _decode_dir(d, keep_controls=False):
            T.true(name.startswith("0003-"), "current session kept")
            evs += [r.text for r in recs if r.type == "event"]
        T.true(len([t for t in evs if t.startswith("flash low")]) >= 1, "degradation logged")
        T.true("event 1900" in evs, "events still logged after control records stopped")
    finally:
        _rmtree(d)


class _Track:
    def __init__(self):
        self.name = "loop"
        self.waypoints = [_Wp(514950000, 36100000), _Wp(514960000, 36110000)]


class _Wp:
    def __init__(self, lat, lon):
        self.lat_e7 = lat
        self.lon_e7 = lon
        self.speed_mps = 1.5
        self.name = ""
        self.radius_m = None


def test_application_interface():
    from trackpilot.nav.fix import Fix

    d = _tmpdir()
    try:
        calls = []

        def statvfs(path):
            calls.append(path)
            return (4096, 4096, 1000, 900, 900, 0, 0, 0, 0, 255)  # 3.7 MB free

        lg = Logger(d, max_file_bytes=100000, min_free_bytes=50000, flush_ms=500,
                    statvfs=statvfs)
        T.eq(lg.low_water_bytes, 50000)
        lg.track(_Track())  # the app loads the track before the session starts
        lg.event("TRACK", "loaded", 5)
        lg.open_session("1.2.3", "cafe", "loop", "watchdog", 77)
        T.eq(calls[0], d)
        fix = Fix()
        fix.t_ms = 1234
        fix.itow_ms = 5000
        fix.pos_valid = True
        fix.lat_e7 = 514951111
        fix.lat_hp = -42
        fix.lon_e7 = 36101111
        fix.lon_hp = 17
        fix.rtk = 3
        fix.num_sv = 27
        fix.heading_valid = True
        fix.heading_deg = 123.45
        fix.heading_acc_deg = 0.3
        rec = lg.rec
        rec.fill_fix(fix)
        rec.xte_m = 0.37
        rec.path_xte_m = -0.12
        lg.control(rec)
        lg.event("BOOT", "hello", 1234)
        lg.close()
        recs = _decode_dir(d)[0][1]
        T.eq([r.type for r in recs], ["header", "track", "event", "control", "event"])
        T.eq(recs[0].get("fw"), "1.2.3")
        T.eq(recs[0].get("reset"), "watchdog")
        T.eq(recs[1].track_id, "loop")
        T.eq(len(recs[1].waypoints), 2)
        c = recs[3]
        T.eq((c.t_ms, c.itow_ms, c.lat_e7, c.lat_hp, c.lon_e7, c.lon_hp, c.rtk, c.num_sv),
             (1234, 5000, 514951111, -42, 36101111, 17, 3, 27))
        T.true(c.pos_valid and c.heading_valid and not c.vel_valid)
        T.near(c.heading_deg, 123.45, 0.006)
        T.near(c.path_xte_m, -0.12, 0.006)
    finally:
        _rmtree(d)


class _FailingFile:
    """A real file whose writes fail with ENOSPC after `ok` of them (the header's lines)."""

    def __init__(self, path, mode, ok):
        self.f = open(path, mode)
        self.ok = ok

    def write(self, b):
        if self.ok[0] <= 0:
            raise OSError(28)
        self.ok[0] -= 1
        return self.f.write(b)

    def flush(self):
        self.f.flush()

    def close(self):
        self.f.close()


def test_header_failing_midway_leaves_no_file():
    d = _tmpdir()
    try:
        ok = [4]  # the header goes out a line at a time: the 5th write fails, inside it
        lg = Logger(d, fw_version="t", open_fn=lambda p, m: _FailingFile(p, m, ok), space_check_ms=1000)
        lg.start(0, reset_cause="power_on")
        T.eq(os.listdir(d), [], "a file without a whole header is removed")
        T.eq(lg.part, -1)
        lg.event("BOOT", "kept in the buffer", 5)
        ok[0] = 10 ** 6  # space again: after the back-off the next flush opens part 0
        lg.tick(500)
        T.eq(os.listdir(d), [])
        lg.tick(1500)
        lg.close()
        T.eq(os.listdir(d), ["0001-00.tpl"])
        recs = _decode_dir(d)[0][1]
        T.eq([r.type for r in recs], ["header", "event"])
        T.eq(recs[0].get("reset"), "power_on")
        T.true(recs[1].text.startswith("logging resumed after dropping 0 control, 1 event"), recs[1].text)
        T.eq(lg.dropped_events, 1)  # the event logged while the flash was full
    finally:
        _rmtree(d)
