"""Session log files on flash: buffered, flushed on a timer, rotated by size, never crashing.

Files: ROOT/SSSS-PP.tpl (session SSSS, part PP). A session starts at boot (one per power-up);
a part is rotated to the next when it would exceed `max_file_bytes`; every part starts with its
own header, the track and a keyframe, so each file decodes on its own.

Flushing: records collect in a preallocated RAM buffer; `tick(t_ms)` writes and flushes it every
`flush_ms` (littlefs keeps nothing since the last flush on power loss), so at most about that much
is lost. A full buffer is written at once.

Flash space (checked at every new part and every `space_check_ms`, `free_fn()` -> bytes). The
retention budget (docs/LOG_FORMAT.md): logs may fill the filesystem down to a reserve of
low_water_bytes (config log.min_free_bytes), at most 1/8 of the filesystem when statvfs gives its
size, so a small filesystem is not all reserve. A new part does not reserve its size up front
(that deleted every older session at the first boot on a small filesystem); the periodic check
deletes as the part grows.
  1. free < low_water_bytes: delete whole older sessions, oldest first, never the current one;
  2. still free < control_reserve_bytes: drop control records (counted in dropped_control),
     keep writing events;
  3. free < event_reserve_bytes or a write fails with ENOSPC: drop everything (counted),
     retry at the next flush. Logging resumes by itself when space returns, and says so in an event.
Nothing here raises to the caller once the logger is built.

Usage:
    lg = Logger("/log", fw_version="0.3", max_file_bytes=256 * 1024, statvfs=os.statvfs)
    lg.start(t_ms, reset_cause="power_on", config_hash="a1b2c3", track_id="loop")
    lg.track(track)                      # a track.Track, or a list of waypoints and an id
    rec = lg.rec                         # a preallocated logfmt.ControlRecord
    rec.fill_fix(fix); rec.xte_m = ...   # each GNSS epoch
    lg.control(rec)
    lg.event("MODE", "STANDBY->AUTO: HMI", t_ms)
    lg.tick(t_ms)                        # often (e.g. every loop); flushes when due
    lg.close()
"""
import os

from trackpilot.compat import const, ticks_diff
from trackpilot.record.logfmt import ControlRecord, LogEncoder

_ENOSPC = const(28)
_MAX_CONTROL_BYTES = const(400)  # worst-case control frame (rotation is decided before encoding)
_MAX_EVENT_BYTES = const(250)  # worst-case EVENT frame (text is cut to 200 bytes)
_EXT = ".tpl"


def parse_name(name):
    """'0012-03.tpl' -> (12, 3); None for other names."""
    if not name.endswith(_EXT):
        return None
    stem = name[: -len(_EXT)]
    dash = stem.find("-")
    if dash <= 0:
        return None
    try:
        return int(stem[:dash]), int(stem[dash + 1 :])
    except ValueError:
        return None


class Logger:
    # Tunables (bytes, ms): the same defaults as config "log" (docs/LOG_FORMAT.md).
    max_file_bytes = 256 * 1024
    # the simulator's loop logs at most 1081 B in any 1 s (flush_ms) but the header, which is
    # written directly (docs/MEMORY.md); a full buffer is written early
    buf_bytes = 1536
    flush_ms = 1000
    space_check_ms = 10000  # statvfs walks littlefs: not every flush
    low_water_bytes = 256 * 1024  # below this, delete older sessions (at most 1/8 of the fs)
    control_reserve_bytes = 64 * 1024  # below this, drop control records, keep events
    event_reserve_bytes = 8 * 1024  # below this, drop everything

    def __init__(self, root, fw_version="", free_fn=None, open_fn=open, key_every=25,
                 statvfs=None, min_free_bytes=None, **tunables):
        # statvfs: os.statvfs-like callable (path -> tuple), used when no free_fn is given.
        # min_free_bytes: config log.min_free_bytes = low_water_bytes (older sessions go below it).
        if min_free_bytes is not None:
            self.low_water_bytes = min_free_bytes
        self._low_water_set = self.low_water_bytes  # before the 1/8-of-the-filesystem cap
        self.fs_bytes = None  # filesystem size, when statvfs tells it
        self._statvfs = statvfs
        for k in tunables:
            if not hasattr(Logger, k):
                raise ValueError("unknown logger setting %s" % k)
            setattr(self, k, tunables[k])
        self.root = root.rstrip("/") or "/"
        self.fw_version = fw_version
        self._free_fn = free_fn
        self._open = open_fn
        self.enc = LogEncoder(key_every)
        self.rec = ControlRecord()  # the application may fill this one in place every epoch
        self._buf = bytearray(self.buf_bytes)
        self._n = 0  # bytes in _buf
        self._buf_control = 0  # records in _buf (counted as dropped if the write fails)
        self._buf_events = 0
        self._f = None
        self._opening = False
        self._file_bytes = 0
        self.session = 0
        self.part = -1
        self.path = ""
        self._hdr = {}
        self._track = None  # (waypoints, track id): its records are encoded when written
        self._now_ms = 0
        self._due_ms = 0
        self._space_due_ms = 0
        self._retry_ms = 0  # after ENOSPC, no new file before this time
        self._full = False
        self.level = 0  # 0 normal, 1 dropping control records, 2 dropping everything
        # Counters (the HMI and telemetry may show them).
        self.dropped_control = 0
        self.dropped_events = 0
        self.deleted_files = 0
        self.write_errors = 0
        self.bytes_written = 0
        self.last_error = ""

    # ------------------------------------------------------------ files and space
    def _path(self, session, part):
        return "%s/%04d-%02d%s" % (self.root, session, part, _EXT)

    def list_files(self):
        """[(session, part, name)] sorted oldest first."""
        try:
            names = os.listdir(self.root)
        except OSError:
            return []
        out = []
        for name in names:
            sp = parse_name(name)
            if sp:
                out.append((sp[0], sp[1], name))
        out.sort()
        return out

    def free_bytes(self):
        try:
            if self._free_fn:
                return self._free_fn()
            st = (self._statvfs or os.statvfs)(self.root)
            self.fs_bytes = st[1] * st[2]  # f_frsize * f_blocks
            self.low_water_bytes = min(self._low_water_set, self.fs_bytes // 8)
            return st[1] * st[4]  # f_frsize * f_bavail
        except Exception:  # no statvfs on this port, or the callback failed: unknown
            return 1 << 30  # let the writes find out (ENOSPC is handled)

    def _delete_oldest(self):
        """Delete the oldest session other than the current one; False if there is none."""
        victims = [f for f in self.list_files() if f[0] != self.session]
        if not victims:
            return False
        oldest = victims[0][0]
        for s, _p, name in victims:
            if s == oldest:
                try:
                    os.remove(self.root + "/" + name)
                    self.deleted_files += 1
                except OSError as e:
                    self.last_error = "remove %s: %s" % (name, e)
                    return False
        return True

    def check_space(self, need_bytes=0):
        """Delete old sessions until `need_bytes` more fit above the low-water mark, then set the
        degradation level from what is free. Returns the level."""
        self._space_due_ms = (self._now_ms + self.space_check_ms) & 0x3FFFFFFF
        if self._full and ticks_diff(self._now_ms, self._retry_ms) < 0:
            return self.level  # a write just failed with ENOSPC: trust that, not statvfs
        free = self.free_bytes()
        while free - need_bytes < self.low_water_bytes and self._delete_oldest():
            free = self.free_bytes()
        if free < self.event_reserve_bytes:
            level = 2
        elif free < self.control_reserve_bytes:
            level = 1
        else:
            level = 0
        was = self.level
        if level != was:
            self.level = level
            if level == 1 or (level == 2 and was == 0):
                self.event("LOG", "flash low (%d bytes free): dropping %s" % (
                    free, "control records" if level == 1 else "all records"), self._now_ms)
            if level < was:
                self.event("LOG", "logging resumed after dropping %d control, %d event records"
                           % (self.dropped_control, self.dropped_events), self._now_ms)
        return level

    # ------------------------------------------------------------ session and parts
    def start(self, t_ms, reset_cause="", config_hash="", track_id="", utc="", **extra):
        """Begin a new session (once after boot). Returns the first file's path ("" if it could
        not be opened: the logger keeps trying at each flush)."""
        try:
            os.mkdir(self.root)
        except OSError:
            pass  # exists (or cannot be made: opening reports it)
        files = self.list_files()
        self.session = (files[-1][0] + 1) if files else 1
        self.part = -1
        self._hdr = dict(extra)
        self._hdr.update(reset_cause=reset_cause, config_hash=config_hash, track_id=track_id,
                         utc=utc)
        self._now_ms = t_ms
        self._due_ms = (t_ms + self.flush_ms) & 0x3FFFFFFF
        self._next_part()
        return self.path if self._f is not None else ""

    def open_session(self, fw_version, config_hash, track_id, reset_cause, t_ms, utc=""):
        """start() with the firmware version (the application's call at boot)."""
        self.fw_version = fw_version
        return self.start(t_ms, reset_cause=reset_cause, config_hash=config_hash,
                          track_id=track_id, utc=utc)

    def _next_part(self):
        """Close the current part and open the next one with a header (and the track)."""
        self._opening = True
        try:
            self._open_next()
        finally:
            self._opening = False

    def _open_next(self):
        self._close_file()
        self.part += 1
        self.path = self._path(self.session, self.part)
        self.check_space()  # no room reserved for the whole part: see the module doc
        try:
            self._f = self._open(self.path, "ab")
        except OSError as e:
            self._f = None
            self.write_errors += 1
            self.last_error = "open %s: %s" % (self.path, e)
            return
        self._file_bytes = 0
        h = self._hdr
        extra = {}
        for k in h:
            if k not in ("config_hash", "track_id", "reset_cause", "utc"):
                extra[k] = h[k]
        # the header goes to the file a line at a time (no 2 KB frame buffer on the heap)
        if not self.enc.write_header(
                self._write, fw_version=self.fw_version, config_hash=h.get("config_hash", ""),
                track_id=h.get("track_id", ""), reset_cause=h.get("reset_cause", ""),
                t0_ms=self._now_ms & 0x3FFFFFFF, utc=h.get("utc", ""), session=self.session,
                part=self.part, **extra):
            try:  # a file without a whole header holds nothing: remove it, reuse the number
                os.remove(self.path)
            except OSError:
                pass
            self.part -= 1
            return
        if self._track:
            for rec in self.enc.iter_track(self._track[0], self._track[1]):
                self._write(rec)

    def _close_file(self):
        if self._f is not None:
            try:
                self._f.close()
            except OSError:
                pass
            self._f = None

    def _room_for(self, nbytes):
        """Make sure `nbytes` more fit into the current part: flush and rotate if not."""
        if self._f is None or self._opening:
            return
        if self._file_bytes + self._n + nbytes > self.max_file_bytes:
            self.flush()
            self._next_part()

    # ------------------------------------------------------------ writing
    def _write(self, data):
        """Write now. Returns False on failure (then the file is closed; the next flush opens
        the next part)."""
        if self._f is None:
            return False
        try:
            self._f.write(data)
        except OSError as e:
            self.write_errors += 1
            self.last_error = "write %s: %s" % (self.path, e)
            if e.args and e.args[0] == _ENOSPC:
                # Back off: statvfs may still say there is room (littlefs counts lazily).
                self.level = 2
                self._full = True
                self._retry_ms = (self._now_ms + self.space_check_ms) & 0x3FFFFFFF
            # The file may now end in a partial record (the decoder skips it); the next control
            # record must not depend on records that were lost.
            self.enc.force_keyframe()
            self._close_file()
            return False
        self._file_bytes += len(data)
        self.bytes_written += len(data)
        return True

    def _queue(self, data, is_event):
        n = len(data)
        if self._n + n > len(self._buf):
            self.flush()
            if self._n + n > len(self._buf):  # the flush failed, or a record larger than the buffer
                if not (self._n == 0 and self._write(data)):
                    self._dropped(is_event)
                return
        self._buf[self._n : self._n + n] = data
        self._n += n
        if is_event:
            self._buf_events += 1
        else:
            self._buf_control += 1

    def _dropped(self, is_event, count=1):
        if is_event:
            self.dropped_events += count
        else:
            self.dropped_control += count
            self.enc.force_keyframe()  # the next record must not be a delta against a lost one

    def control(self, rec):
        """Log one control step (a filled logfmt.ControlRecord)."""
        if self.level >= 1 or self._f is None:  # no file: the chain must restart in the next one
            self._dropped(False)
            return
        self._room_for(_MAX_CONTROL_BYTES)
        self._queue(self.enc.encode_control(rec), False)

    def event(self, kind, text, t_ms):
        """Log an event (mode change with reason, fault, keystroke, confirmation, config ...)."""
        if self.level >= 2:
            self._dropped(True)
            return
        self._room_for(_MAX_EVENT_BYTES)  # before encoding: rotating may log an event itself
        self._queue(self.enc.encode_event(kind, text, t_ms), True)

    def track(self, waypoints, track_id=""):
        """Log the track (written again at the start of every later part of this session).
        `waypoints`: a list of waypoints, or a track.Track (its .waypoints and .name)."""
        if hasattr(waypoints, "waypoints"):
            track_id = track_id or getattr(waypoints, "name", "") or ""
            waypoints = waypoints.waypoints
        # kept as the waypoints, not as bytes: a 2000-waypoint track's records are ~25 KB
        self._track = (waypoints, track_id)
        if not self.session:
            return  # before start(): the first part writes it after its header
        if self.level >= 2:
            self._dropped(True)
            return
        total = 0
        for rec in self.enc.iter_track(waypoints, track_id):
            total += len(rec)
        self._room_for(total)
        for rec in self.enc.iter_track(waypoints, track_id):
            self._queue(rec, True)

    def tick(self, t_ms):
        """Call often (every loop is fine): flushes every `flush_ms`, checks space now and then."""
        self._now_ms = t_ms
        if ticks_diff(t_ms, self._space_due_ms) >= 0:
            self.check_space()
        if ticks_diff(t_ms, self._due_ms) >= 0:
            self._due_ms = (t_ms + self.flush_ms) & 0x3FFFFFFF
            self.flush()

    def flush(self):
        """Write the buffer to flash and sync the file now."""
        if self._f is None and self.session and not self._opening:
            if self._full and ticks_diff(self._now_ms, self._retry_ms) < 0:
                self._n = 0  # the buffer holds only records from before the failure
                self._dropped(False, self._buf_control)
                self._dropped(True, self._buf_events)
                self._buf_control = self._buf_events = 0
                return
            self._full = False
            self._next_part()  # after a failed open or write
        n = self._n
        if not n:
            return
        ok = self._write(memoryview(self._buf)[:n])
        if ok:
            try:
                self._f.flush()  # littlefs: this is the sync that survives power loss
            except OSError as e:
                ok = False
                self.write_errors += 1
                self.last_error = "flush %s: %s" % (self.path, e)
        if not ok:
            self._dropped(False, self._buf_control)
            self._dropped(True, self._buf_events)
        self._n = 0
        self._buf_control = 0
        self._buf_events = 0

    def close(self):
        """Flush and close (call before a planned power-off or reset)."""
        self.flush()
        self._close_file()
