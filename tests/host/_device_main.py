# A stand-in for firmware/main.py under the MicroPython unix port, on a pseudo-terminal: the
# tests drive it with the real mpremote. cwd plays the board's flash root (relative paths).
#
# It runs the REAL maintenance loop (trackpilot.maint.supervise: guard, Python raw REPL, restart)
# around a small app that has the interface supervise() uses (mm, clock, event, stop_event, run,
# load_track) with the real mode machine and the real track module. The full App cannot run here
# yet without a simulator link; see docs/DEVICE.md.
#
# Usage: micropython _device_main.py [STANDBY|AUTO] [idle_s] [limit_s]
# Files in cwd: events.txt (one event a line), mode.txt (the test writes STANDBY/AUTO to change
# the mode while it runs), log/ (files to pull), tracks/.
import sys

try:
    import asyncio
except ImportError:
    import uasyncio as asyncio
import time

from trackpilot import maint
from trackpilot import modes as M


class StandInApp:
    def __init__(self, mode):
        self.mm = M.ModeMachine()
        self.clock = time.ticks_ms
        self.stop_event = asyncio.Event()
        self.maint_requested = False
        self.track_id = ""
        self.runs = 0
        self.feeds = 0
        if mode == "AUTO":
            self.mm.engage(self.clock(), None, "test")
        self.mm.drain_events()

    def event(self, kind, text):
        with open("events.txt", "a") as f:
            f.write("%s %s\n" % (kind, text))

    def load_track(self, path):
        from trackpilot import track

        if self.mm.mode == M.AUTO:
            return False, "only in STANDBY"
        try:
            with open(path) as f:
                text = f.read()
            trk = track.parse_track_csv(text)
        except (OSError, ValueError) as e:
            self.event("TRACK", "rejected %s: %s" % (path, e))
            return False, str(e)
        self.event("TRACK", "loaded %s: %d waypoints" % (path, len(trk.waypoints)))
        return True, "ok"

    def feed(self):
        self.feeds += 1

    async def run(self):
        self.runs += 1
        self.event("RUN", "app run %d, mode %s" % (self.runs, M.MODE_NAMES[self.mm.mode]))
        while not self.stop_event.is_set():
            try:
                with open("mode.txt") as f:
                    want = f.read().strip()
            except OSError:
                want = ""
            t = self.clock()
            if want == "STANDBY" and self.mm.mode != M.STANDBY:
                self.mm.standby(t, "test")
            elif want == "AUTO" and self.mm.mode != M.AUTO:
                self.mm.engage(t, None, "test")
            for kind, text in self.mm.drain_events():
                self.event(kind, text)
            self.feed()
            try:
                await asyncio.wait_for_ms(self.stop_event.wait(), 100)
            except asyncio.TimeoutError:
                pass
        self.event("STOP", "application stopped")


def main():
    mode = sys.argv[1] if len(sys.argv) > 1 else "STANDBY"
    idle_s = float(sys.argv[2]) if len(sys.argv) > 2 else maint.IDLE_S
    limit_s = float(sys.argv[3]) if len(sys.argv) > 3 else maint.LIMIT_S
    app = StandInApp(mode)
    app.load_track("tracks/active.csv")
    maint.supervise(app, feed=app.feed, track_path="tracks/active.csv", idle_s=idle_s, limit_s=limit_s)


main()
