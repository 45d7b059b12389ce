# A stand-in for firmware/main.py under the MicroPython unix port, on a pseudo-terminal: the
# tests drive it with the real mpremote. cwd plays the board's flash root (relative paths).
#
# It runs the REAL maintenance loop (trackpilot.board.maint.supervise: guard, Python raw REPL, restart)
# around the REAL application (trackpilot.app.App) on the bench wiring (wiring_bench: no devices
# attached, real clock), with `--stand-in` a small app with the same interface instead.
# The test switches modes through mode.txt (a person's STANDBY; AUTO is forced on the mode
# machine, as engaging needs a GNSS fix and a pilot that a bench board does not have).
#
# Usage: micropython _device_main.py [STANDBY|AUTO] [idle_s] [limit_s] [--stand-in]
# Files in cwd: events.txt (one event a line), mode.txt (the test writes STANDBY/AUTO to change
# the mode while it runs), log/ (files to pull), tracks/.
import sys

try:
    import asyncio
except ImportError:
    import uasyncio as asyncio
import time

from trackpilot.board import maint
from trackpilot.core import modes as M


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
        from trackpilot.nav import track

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


def real_app(mode):
    from trackpilot import config
    from trackpilot.app import App
    from trackpilot.sim.wiring_bench import Wiring

    class BenchApp(App):
        """The real App; events also go to events.txt for the test, modes follow mode.txt."""

        def event(self, kind, text, t_ms=None):
            App.event(self, kind, text, t_ms)
            with open("events.txt", "a") as f:
                f.write("%s %s\n" % (kind, text))

        async def _follow_mode_file(self):
            while True:
                try:
                    with open("mode.txt") as f:
                        want = f.read().strip()
                except OSError:
                    want = ""
                t = self.clock()
                if want == "STANDBY" and self.mm.mode != M.STANDBY:
                    self.command("STANDBY", "test")
                elif want == "AUTO" and self.mm.mode != M.AUTO:
                    self.mm.engage(t, None, "test")
                    self.drain_events()
                await asyncio.sleep_ms(100)

        async def run(self):
            self.runs_seen = getattr(self, "runs_seen", 0) + 1
            self.event("RUN", "app run %d, mode %s" % (self.runs_seen, M.MODE_NAMES[self.mm.mode]))
            asyncio.create_task(self._follow_mode_file())
            await App.run(self)

    cfg = config.defaults()
    # nothing is attached: a forced AUTO must stay AUTO (degraded) during the test, not fall to
    # ALARM for a motor controller or GNSS that a bench board does not have
    cfg["motor"]["expect_replies"] = False
    cfg["modes"]["gnss_hold_s"] = 120.0
    w = Wiring("appdata")  # the app's own log and state, apart from the files the test pulls
    app = BenchApp(w, cfg, (), reset_cause="power-on")
    if mode == "AUTO":
        app.mm.engage(app.clock(), None, "test")
        app.drain_events()
    app.feed = w.feed_watchdog
    return app


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    mode = args[0] if args else "STANDBY"
    idle_s = float(args[1]) if len(args) > 1 else maint.IDLE_S
    limit_s = float(args[2]) if len(args) > 2 else maint.LIMIT_S
    app = StandInApp(mode) if "--stand-in" in sys.argv else real_app(mode)
    app.load_track("tracks/active.csv")
    maint.supervise(app, feed=app.feed, track_path="tracks/active.csv", idle_s=idle_s, limit_s=limit_s)


main()
