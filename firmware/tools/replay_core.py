"""Replay the decision core from a simulator journal and check everything it decided (host tool).

    micropython firmware/tools/replay_core.py JOURNAL CONFIG.json LOG.tpl [LOG2.tpl ...] [--seed N]
    trackpilot replay LOG.tpl ... --config CONFIG.json --journal JOURNAL

JOURNAL is what `sim_main --journal` wrote (trackpilot/sim/journal.py): every call into the core
with its inputs and time. A fresh core (the same class the boat runs, the same configuration and
back-off seed) gets the same calls; then, against the flight log and the journal:
  - every control record (mode, RPM setpoint, keystrokes sent and their net course change,
    heading and speed command, leg, xte, alarms, ... every field at the log's resolution),
  - every event the core logged (mode changes with reasons, alarms, pilot, motor, SeaTalk, NAV),
  - every SeaTalk bus action (each byte written with its parity: the keystrokes on the wire),
  - every motor frame (the RPM setpoint on the wire).
Output (stdout): `MISMATCH ...` lines (the first 20), then `SUMMARY key=value ...`; exit status 0
only when everything matched. `--seed` overrides the back-off seed the journal recorded.
"""
import struct
import sys
from binascii import unhexlify

from trackpilot import config
from trackpilot.core.autopilot import Autopilot
from trackpilot.devices import stlink
from trackpilot.nav.fix import Fix
from trackpilot.nav.track import from_waypoints
from trackpilot.record import logfmt

# events the shell logs itself (files, boot, configuration, network): not the core's decisions
SHELL_KINDS = ("BOOT", "CONFIG", "TRACK", "STOP", "FAULT", "WIFI", "NTRIP", "HMI")
# the fields a control record carries (flags: the validity bits, compared one by one)
REC_FIELDS = [f[0] for f in logfmt.FIELDS if f[0] != "flags"] + ["pos_valid", "heading_valid", "vel_valid", "rtk"]
QUANTIZED = [f[0] for f in logfmt.FIELDS if f[0] != "flags" and (f[1] != 1 or f[4])]


def shell_event(kind, text):
    return kind in SHELL_KINDS or (kind == "GNSS" and text.startswith("receiver configuration"))


def fnum(s):
    return None if s == "-" else struct.unpack("<d", unhexlify(s))[0]


def hexbytes(s):
    return b"" if s == "-" else unhexlify(s)


def set_fix(fix, a):
    fix.t_ms = int(a[0])
    fix.itow_ms = int(a[1])
    fix.pos_valid = a[2] == "1"
    fix.lat_e7 = int(a[3])
    fix.lon_e7 = int(a[4])
    fix.lat_hp = int(a[5])
    fix.lon_hp = int(a[6])
    fix.rtk = int(a[7])
    fix.num_sv = int(a[8])
    fix.h_acc_m = fnum(a[9])
    fix.heading_valid = a[10] == "1"
    fix.heading_deg = fnum(a[11])
    fix.heading_acc_deg = fnum(a[12])
    fix.vel_valid = a[13] == "1"
    fix.sog_mps = fnum(a[14])
    fix.cog_deg = fnum(a[15])


class Replay:
    """Feeds journal lines to a fresh core and compares as it goes: each control record with the
    next one of the log, each core event with the next core event of the log (streamed: a long
    log does not have to fit in the heap twice)."""

    def __init__(self, cfg, problems, data, seed):
        self.cfg = cfg
        self.problems = problems
        self.seed = seed
        self.tracks = {}  # track name -> waypoints (from the log)
        self.last_track = None
        for r in logfmt.iter_records(data):
            if r.type == "track":
                self.tracks[r.track_id] = r.waypoints
                self.last_track = r.track_id
        self.log_recs = (r for r in logfmt.iter_records(data) if r.type == "control")
        self.log_evs = ((r.kind, r.text, r.t_ms) for r in logfmt.iter_records(data)
                        if r.type == "event" and not shell_event(r.kind, r.text))
        self.fix = Fix()
        self.core = None
        self.n = {"records": 0, "records_identical": 0, "keys_identical": 0, "rpm_identical": 0,
                  "mode_identical": 0, "events": 0, "events_identical": 0, "mode_changes": 0,
                  "mode_changes_identical": 0, "bus_actions": 0, "motor_frames": 0}
        self.mismatches = []
        self.n_mismatches = 0

    def boot(self, seed):
        self.fix = Fix()
        self.core = Autopilot(self.cfg, self.problems, self.fix, stlink.Prng(seed))

    def mismatch(self, text):
        self.n_mismatches += 1
        if len(self.mismatches) < 20:  # the first ones say what went wrong; the count says how much
            self.mismatches.append(text)

    def collect(self):
        core = self.core
        n = self.n
        while True:
            ev = core.pop_event()
            if ev is None:
                break
            logged = next(self.log_evs, None)
            n["events"] += 1
            if ev == logged:
                n["events_identical"] += 1
            else:
                self.mismatch("event %d: replayed %r, logged %r" % (n["events"], ev, logged))
            if ev[0] == "MODE":
                n["mode_changes"] += 1
                n["mode_changes_identical"] += ev == logged
        if core.rec_ready:
            core.rec_ready = False
            self.compare_record(core.rec, next(self.log_recs, None))
        core.state_due = None
        core.wake_seatalk = False

    def compare_record(self, rec, logged):
        n = self.n
        n["records"] += 1
        if logged is None:
            self.mismatch("record %d: replayed, not in the log" % n["records"])
            return
        bad = []
        for name in REC_FIELDS:
            v = getattr(rec, name)
            if name in QUANTIZED:
                v = logfmt.quantized(name, v)  # as the log stores it (scaled, wrapped)
            if v != getattr(logged, name):
                bad.append("%s %r != %r" % (name, v, getattr(logged, name)))
        if bad:
            self.mismatch("record %d t=%d: %s" % (n["records"], logged.t_ms, ", ".join(bad[:4])))
        else:
            n["records_identical"] += 1
        n["keys_identical"] += rec.keys_sent == logged.keys_sent and rec.keys_net_deg == logged.keys_net_deg
        n["rpm_identical"] += rec.rpm_set == logged.rpm_set
        n["mode_identical"] += rec.mode == logged.mode

    def finish(self):
        left_r = sum(1 for _ in self.log_recs)
        left_e = sum(1 for _ in self.log_evs)
        if left_r or left_e:
            self.mismatch("the log has %d more control records and %d more core events than the replay"
                          % (left_r, left_e))

    def line(self, ln):
        a = ln.split()
        code = a[0]
        if code == "B":  # a firmware start: "B <back-off seed>"
            self.boot(int(a[1]) if self.seed is None else self.seed)
            return
        core = self.core
        t = int(a[1])
        if code == "F":
            set_fix(self.fix, a[4:])
            core.on_fix(t, int(a[2]), fnum(a[3]))
        elif code == "G":
            core.on_gnss_watch(t, int(a[2]), fnum(a[3]))
        elif code == "R":
            b = hexbytes(a[2])
            core.on_seatalk_rx(b, len(b), t)
        elif code == "X":
            act = core.seatalk_tx(t)
            want = " ".join(a[2:])
            got = " ".join(str(x) for x in act)
            self.n["bus_actions"] += 1
            if got != want:
                self.mismatch("t=%d SeaTalk bus: replayed %s, logged %s" % (t, got, want))
        elif code == "D":
            core.on_seatalk_tx_done(t, int(a[2]))
        elif code == "P":
            core.on_pilot_tick(t)
        elif code == "M":
            b = hexbytes(a[2])
            core.on_motor_rx(memoryview(b), len(b), t)
        elif code == "K":
            frame = core.motor_tick(t)
            self.n["motor_frames"] += 1
            if (bytes(frame) if frame else b"") != hexbytes(a[2]):
                self.mismatch("t=%d motor frame differs" % t)
        elif code == "W":
            b = hexbytes(a[2])
            core.on_wind_rx(memoryview(b), len(b), t)
        elif code == "E":
            core.on_estop(a[2] == "1", t)
        elif code == "C":
            core.on_key(a[2], a[3], t, fnum(a[4]))
        elif code == "T":
            # the log names the track by its name, the journal by its id: one track per session
            trk = from_waypoints(self.tracks.get(a[2]) or self.tracks[self.last_track])
            core.set_track(trk, a[2], core.progress_for(trk), t)
        elif code == "S":
            core.restore_state({"track_id": a[2], "leg": int(a[3]), "mode": a[4]}, t)
        elif code == "N":
            core.settle(t)
        else:
            raise ValueError("journal: unknown line %r" % ln)
        self.collect()


def main():
    args = [a for a in sys.argv[1:]]
    seed = None  # the journal's own
    if "--seed" in args:
        i = args.index("--seed")
        seed = int(args[i + 1])
        del args[i:i + 2]
    if len(args) < 3:
        raise SystemExit("usage: replay_core.py JOURNAL CONFIG.json LOG.tpl ... [--seed N]")
    journal, cfg_path, logs = args[0], args[1], args[2:]
    cfg, problems = config.load(cfg_path)
    data = b""
    for path in logs:
        with open(path, "rb") as f:
            data += f.read()
    rp = Replay(cfg, problems, data, seed)
    lines = 0
    with open(journal) as f:
        for ln in f:
            ln = ln.strip()
            if ln:
                rp.line(ln)
                lines += 1
    rp.finish()
    for m in rp.mismatches:
        print("MISMATCH " + m)
    n = rp.n
    print("SUMMARY journal_lines=%d %s mismatches=%d" % (
        lines, " ".join("%s=%d" % (k, n[k]) for k in sorted(n)), rp.n_mismatches))
    if rp.n_mismatches:
        sys.exit(1)


main()
