"""The application: the asyncio shell around the decision core.

The shell only moves bytes and time: each task reads a stream (or a pin, or the clock), hands what
it read with the time to the core (core/autopilot.py), writes what the core returned (SeaTalk
bytes, motor frames, throttle, log events and records, the state file, the HMI) and feeds the
watchdog while every task is alive. Every decision is the core's (docs/MODES.md "Who decides
what"); the GNSS parser and the receiver configuration (devices/gnss.py, ubxcfg.py), the logger
and the NTRIP client are the shell's devices: bytes in, records out.

One GNSS epoch (5 Hz, or the receiver's measured rate) is the clock of the control loop: the GNSS
task feeds bytes to the parser and runs the core's control step once per completed epoch; in AUTO,
when epochs stop, the supervisor's look (core.on_gnss_watch, every 100 ms) runs it on the
dead-reckoned position instead (docs/MODES.md "GNSS gaps"). The wiring object
(`board.wiring_esp32.Wiring` or `sim.wiring_sim.Wiring`) provides streams, pins, clock and
storage paths, so the same App runs on the ESP32 and in the simulator.

Usage:
    app = App(wiring, cfg, cfg_problems)
    app.load_track(path)
    asyncio.run(app.run())
"""
import gc

from trackpilot import VERSION
from trackpilot.compat import ticks_add, ticks_diff
from trackpilot.core import modes as M
from trackpilot.core.autopilot import Autopilot
from trackpilot.nav.fix import Fix

try:
    import asyncio
except ImportError:  # pragma: no cover
    import uasyncio as asyncio

# On a small heap (an ESP32 without PSRAM) a collection also runs after every heap/GC_THRESHOLD_DIV
# bytes allocated, at least GC_THRESHOLD_MIN_B: about 10 KB there, which keeps the free heap in one
# piece (docs/MEMORY.md; heap/32 kept the same free block with twice the collections). Not on a
# large heap (PSRAM, the unix port's megabytes): nothing to fix there, and a sweep grows with the
# heap (it made the simulator 4x slower).
GC_THRESHOLD_MIN_B = 4096
GC_THRESHOLD_DIV = 16
GC_THRESHOLD_HEAP_MAX_B = 262144
TASKS = ("gnss", "seatalk_rx", "seatalk_tx", "pilot", "motor", "wind", "inputs", "logger", "telemetry")


def _error_text(e):
    """An exception as one line for an event: the message, else the exception's type."""
    text = str(e)
    return text if text else type(e).__name__


class App:
    def __init__(self, wiring, cfg, cfg_problems=(), reset_cause="unknown", core_class=Autopilot):
        # from here on also collect after every heap/GC_THRESHOLD_DIV allocated: an epoch's allocations
        # then stay near the bottom of the free heap instead of sweeping through it, so the values
        # kept from one epoch to the next do not cut the rest into pieces (docs/MEMORY.md)
        heap_b = gc.mem_free() + gc.mem_alloc()
        if heap_b <= GC_THRESHOLD_HEAP_MAX_B:
            gc.threshold(max(GC_THRESHOLD_MIN_B, heap_b // GC_THRESHOLD_DIV))
        from trackpilot.record import logger

        # the largest buffers first (the log's 2 KB write buffer and 2 KB header frame), while the
        # heap is still one block; the other modules are imported after them (here and in the core)
        self.log = logger.Logger(
            wiring.log_dir,
            max_file_bytes=cfg["log"]["max_file_bytes"],
            min_free_bytes=cfg["log"]["min_free_bytes"],
            flush_ms=cfg["log"]["flush_ms"],
            statvfs=wiring.statvfs,
        )
        from trackpilot.devices import gnss

        self.w = wiring
        self.cfg = cfg
        self.clock = wiring.ticks_ms
        self.fix = Fix()
        self.gnss = gnss.GnssParser(self.fix, heading_offset_deg=cfg["boat"]["heading_offset_deg"])
        self.cfg_problems = list(cfg_problems)
        # core_class: the simulator's journaling subclass (sim/journal.py) writes every input down
        self.core = core_class(cfg, self.cfg_problems, self.fix, wiring.rand, rec=self.log.rec)
        self.reset_cause = reset_cause
        self.alive = {}
        self.stop_event = asyncio.Event()
        self.peak_heap = 0  # largest live heap (bytes, right after a collection)
        self._st_wake = asyncio.Event()
        self._empty = bytearray(0)
        self._last_gc_ms = self.clock()
        self.gc_max_us = 0
        self.gc_runs = 0
        try:
            from time import ticks_us

            self.us = ticks_us  # only for measuring GC pauses (wall time, also in simulation)
        except ImportError:  # pragma: no cover
            self.us = lambda: 0
        self.input_period_ms = getattr(wiring, "input_period_ms", 50)  # button sampling
        self.profile = False  # measure each control epoch (profiled_feed); sim_main --profile
        self.profile_out = None  # an open file for the samples (else they stay in prof_us/prof_alloc)
        self.prof_us = []
        self.prof_alloc = []
        self._prof_acc = [0, 0]
        self.on_stable = None  # called once after bootguard.STABLE_MS with every task alive
        self._stable_due_ms = None

    def __getattr__(self, name):
        # the core's state (mm, progress, pilot, refusal ...) for the HMI, maintenance and tests
        if name == "core":
            raise AttributeError(name)
        return getattr(self.core, name)

    # ------------------------------------------------------------------ the core's outputs
    def flush(self):
        """Write what the core left: events, the control record, the state file; wake the
        SeaTalk writer when keys were queued. Called after every call into the core."""
        core = self.core
        while True:
            ev = core.pop_event()
            if ev is None:
                break
            self.event(ev[0], ev[1], ev[2])
        hmi = getattr(self.w, "hmi", None)
        if hmi is not None:
            for kind, text in hmi.drain_events():
                self.event(kind, text)
        if core.rec_ready:
            core.rec_ready = False
            self.log.control(core.rec)
        if core.state_due is not None:
            st = core.state_due
            core.state_due = None
            self.write_state(st)
        if core.wake_seatalk:
            core.wake_seatalk = False
            self._st_wake.set()

    def drain_events(self):
        """The parts' pending events through the core, then out (tests and the device harness
        poke the mode machine directly)."""
        self.core.settle(self.clock())
        self.flush()

    def event(self, kind, text, t_ms=None):
        """Log an event (t_ms: when the core decided it; default now)."""
        self.log.event(kind, text, self.clock() if t_ms is None else t_ms)
        self.w.debug("%s %s" % (kind, text))

    # ------------------------------------------------------------------ track and state files
    def load_track(self, path):
        """Read, validate and hand a track file to the core; only in STANDBY. Never raises: a bad
        or too large file, or one that does not fit in memory, is refused with a TRACK event and
        the active track stays. Returns (ok, message)."""
        from trackpilot.nav import track

        refusal = self.core.track_refusal()
        if refusal:
            return False, refusal
        new = None
        try:
            new, new_id = track.load_file(path)
            warnings = track.validate(new, self.cfg["boat"])
            prog = self.core.progress_for(new)
        except MemoryError:
            new = None
            gc.collect()
            msg = "track %s rejected: not enough memory to load it (%d B free); the previous track stays" % (
                path, gc.mem_free())
            self.event("TRACK", msg)
            return False, msg
        except Exception as e:  # a file error, a bad track, anything: the app goes on without it
            msg = "track %s rejected: %s" % (path, _error_text(e))
            self.event("TRACK", msg)
            return False, msg
        self.core.set_track(new, new_id, prog, self.clock())
        self.event("TRACK", "loaded %s: %d waypoints, id %s" % (path, len(new.waypoints), new_id))
        for w in warnings:
            self.event("TRACK", "warning: " + w)
        self.log.track(new)
        self.restore_state()
        return True, "ok"

    def restore_state(self):
        """After a reset: the state file to the core (it knows the leg, and stays in STANDBY)."""
        import json

        try:
            with open(self.w.state_path) as f:
                st = json.loads(f.read())
        except (OSError, ValueError):
            return
        if isinstance(st, dict):
            self.core.restore_state(st, self.clock())
            self.flush()

    def write_state(self, st):
        import json

        from trackpilot.config import write_atomic

        try:
            write_atomic(self.w.state_path, json.dumps(st))
        except OSError as e:
            self.event("FAULT", "state not saved: %s" % e)

    # ------------------------------------------------------------------ inputs to the core
    def correction_age_s(self, t_ms):
        """Age of the last RTCM frame forwarded to the receiver, None if none (or no NTRIP)."""
        if not self.cfg["ntrip"]["enabled"]:
            return self.w.correction_age_s(t_ms)
        from trackpilot.devices import ntrip  # imported only with NTRIP on (docs/MEMORY.md)

        s = ntrip.current_session()
        return s.age_s(t_ms) if s is not None else None

    def gga_bytes(self):
        from trackpilot.devices import nmea_out

        return nmea_out.gga(self.fix) if self.fix.pos_valid else None

    def command(self, name, source="HMI"):
        """A person's command (HMI button, remote box, host): to the core; PAGE turns the display."""
        t = self.clock()
        if name == "PAGE":
            self.w.next_page()
        self.core.on_key(name, source, t, self.correction_age_s(t))
        self.flush()

    def control_step(self, t_ms):
        """One completed GNSS epoch: the core's control step, then its outputs."""
        self.core.on_fix(t_ms, self.gnss.interval_ms, self.correction_age_s(t_ms))
        self.flush()

    # ------------------------------------------------------------------ tasks
    def grid_ms(self, period_ms):
        """Sleep so that periodic tasks wake on a common grid of the clock: they then run in the
        same scheduler pass (fewer wake-ups on the ESP32, fewer lockstep steps in simulation)."""
        return period_ms - (self.clock() % period_ms)

    def beat(self, name):
        self.alive[name] = self.clock()

    def _on_gnss_msg(self, kind):
        from trackpilot.devices import gnss

        if (kind == gnss.K_ACK_ACK or kind == gnss.K_ACK_NAK) and self.gnss_cfg is not None:
            r = self.gnss.ack
            out = self.gnss_cfg.on_ack(r.cls, r.id, kind == gnss.K_ACK_ACK, self.clock())
            if out:
                self.w.gnss_uart.write(out)

    def gnss_config_poll(self, t_ms):
        """Receiver configuration (CFG-VALSET, 5 Hz, our messages): resend on timeout, log the end."""
        from trackpilot.devices import ubxcfg

        s = self.gnss_cfg
        out = s.poll(t_ms)
        if out:
            self.w.gnss_uart.write(out)
        if s.state != ubxcfg.BUSY and not self._gnss_cfg_reported:
            self._gnss_cfg_reported = True
            self.gnss_cfg_failed = s.state != ubxcfg.DONE  # shown on the HMI's GNSS page
            self.event("GNSS", "receiver configuration %s: %s" % (
                "done" if s.state == ubxcfg.DONE else "FAILED (running with what it sends)",
                s.log[-1][1] if s.log else ""))
            # finished: it answers nothing more, so its frames and log go (docs/MEMORY.md)
            self.gnss_cfg = None
            self.gnss.on_msg = None

    def task_gnss(self):
        """The receiver's configuration starts; then its bytes are pumped to the parser (the
        coroutine returned is the task: one frame, not one awaiting another)."""
        from trackpilot.devices import ubxcfg

        self.gnss_cfg = ubxcfg.ConfigSession(ubxcfg.valset_frames(ubxcfg.rover_items()))
        self._gnss_cfg_reported = False
        self.gnss_cfg_failed = False
        self.gnss.on_msg = self._on_gnss_msg
        first = self.gnss_cfg.start(self.clock())
        if first:
            self.w.gnss_uart.write(first)
        return self.pump("gnss", self.w.gnss_uart, 256, self.on_gnss_bytes)

    def on_gnss_bytes(self, mv, n, t):
        if self.profile:
            self.profiled_feed(mv, n, t)
        elif self.gnss.feed(mv, n, t):  # an epoch completed
            self.control_step(t)

    def profiled_feed(self, mv, n, t):
        """The GNSS feed and the control step with CPU time (ticks_us) and bytes allocated
        (gc.mem_alloc, collector off meanwhile) measured; summed over the feeds of an epoch and
        recorded when it completes (prof_us, prof_alloc). Only with `profile` set (sim_main
        --profile, the benchmark); the normal path above has no measuring in it."""
        from time import ticks_diff as us_diff

        if gc.mem_free() < 32768:
            gc.collect()  # outside the window: with the collector off, a full heap cannot be reclaimed
        gc.disable()
        try:
            a0 = gc.mem_alloc()
            t0 = self.us()
            epochs = self.gnss.feed(mv, n, t)
            if epochs:
                self.control_step(t)
            dt = us_diff(self.us(), t0)
            da = gc.mem_alloc() - a0
        finally:
            gc.enable()
        self._prof_acc[0] += dt
        self._prof_acc[1] += da
        if epochs:
            self.prof_us.append(self._prof_acc[0])
            self.prof_alloc.append(self._prof_acc[1])
            self._prof_acc[0] = 0
            self._prof_acc[1] = 0
            if len(self.prof_us) >= 250:
                self.profile_flush()

    def profile_flush(self):
        """Write the collected samples to `profile_out` ("us bytes" a line) so that a long run
        does not keep them on the heap it measures."""
        f = self.profile_out
        if f is not None:
            for i in range(len(self.prof_us)):
                f.write("%d %d\n" % (self.prof_us[i], self.prof_alloc[i]))
            self.prof_us = []
            self.prof_alloc = []

    async def pump(self, name, uart, size, handle):
        """Read a stream as bytes come; each chunk goes with its time to handle(mv, n, t_ms).
        name: the task's heartbeat (None: none)."""
        reader = asyncio.StreamReader(uart)
        mv = memoryview(bytearray(size))
        while True:
            n = await reader.readinto(mv)
            if name is not None:
                self.beat(name)
            if n:
                handle(mv, n, self.clock())

    def task_seatalk_rx(self):
        return self.pump("seatalk_rx", self.w.seatalk_uart, 32, self.on_seatalk_bytes)

    def on_seatalk_bytes(self, mv, n, t):
        self.core.on_seatalk_rx(mv, n, t)
        self.flush()

    async def task_seatalk_tx(self):
        """The SeaTalk bus: one byte at a time with its parity, as the core's link says."""
        from trackpilot.devices import stlink

        uart = self.w.seatalk_uart
        core = self.core
        one = bytearray(1)
        while True:
            self.beat("seatalk_tx")
            t = self.clock()
            act = core.seatalk_tx(t)
            kind = act[0]
            if kind == stlink.WRITE:
                one[0] = act[1]
                uart.init(parity=0 if act[2] == "E" else 1)  # waits for TX to drain on the ESP32
                uart.write(one)
                await asyncio.sleep_ms(0)
            else:
                # WAIT: until the link's time; idle: until the pilot's own timers, or a new epoch,
                # a received byte or a queued key wakes it. At least 1 ms: a wait that is already
                # due must still let time pass, or this task spins without the clock (and the
                # bus) moving on; that once happened when st2000.next_due_ms said "now" for a key
                # poll() held back.
                self._st_wake.clear()
                due = ticks_diff(act[1], t) if kind == stlink.WAIT else core.pilot_next_due_ms(t)
                try:
                    await asyncio.wait_for_ms(self._st_wake.wait(), max(1, due))
                except asyncio.TimeoutError:
                    pass
            core.on_seatalk_tx_done(t, self.clock())
            self.flush()

    async def task_pilot(self):
        """The pilot driver's timers: confirmations, hang detection, status timeout."""
        while True:
            self.beat("pilot")
            self.core.on_pilot_tick(self.clock())
            self.flush()
            await asyncio.sleep_ms(self.grid_ms(100))

    async def task_motor(self):
        uart = self.w.motor_uart
        period = self.cfg["motor"]["keepalive_ms"]
        if uart is not None:
            asyncio.create_task(self.pump(None, uart, 64, self.core.on_motor_rx))
        while True:
            self.beat("motor")
            frame = self.core.motor_tick(self.clock())  # also runs the link-loss and battery timers
            if frame and uart is not None:
                uart.write(frame)
            self.w.set_throttle(self.core.throttle_duty)
            self.flush()
            await asyncio.sleep_ms(self.grid_ms(period))

    def task_wind(self):
        if self.w.wind_uart is None:
            return None  # no sensor: no task
        return self.pump("wind", self.w.wind_uart, 128, self.core.on_wind_rx)

    async def task_inputs(self):
        """E-stop and commands (buttons, remote) to the core; LEDs, buzzer and display."""
        while True:
            self.beat("inputs")
            t = self.clock()
            self.core.on_estop(self.w.estop_active(), t)
            self.flush()
            for name, source in self.w.poll_commands(t):
                self.command(name, source)
            self.w.show(self, t)
            await asyncio.sleep_ms(self.grid_ms(self.input_period_ms))

    async def task_logger(self):
        while True:
            self.beat("logger")
            self.log.tick(self.clock())
            await asyncio.sleep_ms(self.grid_ms(200))

    def nmea_sentences(self):
        """GGA, RMC, HDT, XTE, RMB and APB for chart plotters (UDP 10110 on the boat)."""
        from trackpilot.devices import nmea_out

        core = self.core
        fix = self.fix
        out = nmea_out.gga(fix) + nmea_out.rmc(fix) + nmea_out.hdt(fix)
        p = core.progress
        if p is not None and fix.pos_valid:
            auto = core.mm.mode == M.AUTO
            out += nmea_out.xte(p.xte_m, valid=auto)
            out += nmea_out.route(fix, p, valid=auto, heading_cmd_deg=core.heading_cmd_deg if auto else None)
        return out

    async def task_telemetry(self):
        period = self.cfg["telemetry"]["period_ms"]
        while True:
            self.beat("telemetry")
            self.w.send_status(self, self.clock())
            self.w.send_nmea(self.nmea_sentences())
            await asyncio.sleep_ms(self.grid_ms(period))

    async def task_supervisor(self):
        """An epoch closed by its timeout, the receiver configuration, the core's GNSS watch (gap
        timer, staleness), NTRIP, task heartbeats and the watchdog, GC and the heap watermark."""
        while True:
            t = self.clock()
            if self.gnss.feed(self._empty, 0, t):  # an epoch closed by its timeout (no more bytes)
                self.control_step(t)
            if getattr(self, "gnss_cfg", None) is not None:
                self.gnss_config_poll(t)
            self.core.on_gnss_watch(t, self.gnss.interval_ms, self.correction_age_s(t))
            self.flush()
            self.watch_ntrip()
            dead = self.dead_tasks(t)
            if dead:
                self.event("FAULT", "task not alive: %s; watchdog not fed" % ",".join(dead))
            else:
                self.w.feed_watchdog()
                self._check_stable(t)
            if ticks_diff(t, self._last_gc_ms) >= 1000:
                # collect once a second between control epochs: short, predictable pauses instead
                # of one long one whenever the heap runs full; the live heap after it is the
                # figure that says whether the app fits
                self._last_gc_ms = t
                t0 = self.us()
                gc.collect()
                pause_us = self.us() - t0
                if pause_us > self.gc_max_us:
                    self.gc_max_us = pause_us
                self.gc_runs += 1
                live = gc.mem_alloc()
                if live > self.peak_heap:
                    self.peak_heap = live
            await asyncio.sleep_ms(self.grid_ms(100))  # the GNSS gap timer needs < 0.5 s

    def start_ntrip(self):
        """RTK corrections: caster -> GNSS UART (with Wi-Fi: once the link is first up, task_wifi)."""
        from trackpilot.devices import ntrip  # imported only when it starts (docs/MEMORY.md)

        self.ntrip_task = asyncio.create_task(ntrip.run_client(
            self.cfg["ntrip"], self.w.gnss_uart.write, self.clock, gga=self.gga_bytes, events=self.event))

    def watch_ntrip(self):
        """The NTRIP client never ends by itself; if it did (a bug), log it and start it again."""
        task = getattr(self, "ntrip_task", None)
        if task is not None and task.done() and not self.stop_event.is_set():
            self.ntrip_restarts += 1
            self.event("FAULT", "NTRIP task ended (restart %d)" % self.ntrip_restarts)
            self.start_ntrip()

    async def task_wifi(self):
        """Wi-Fi (wifi.WifiLink, built by the board's wiring): start, then poll; its state goes
        to the HMI and the status datagram; NTRIP waits for the first link."""
        link = self.w.wifi
        for text in link.start(self.clock()):
            self.event("WIFI", text)
        while True:
            for text in link.poll(self.clock()):
                self.event("WIFI", text)
            if link.is_up() and self.cfg["ntrip"]["enabled"] and self.ntrip_task is None:
                self.start_ntrip()  # once; the client reconnects by itself, watch_ntrip restarts it
            await asyncio.sleep_ms(500)

    def _check_stable(self, t):
        """Tell the boot-loop guard once the app has run stably (bootguard.py)."""
        if self.on_stable is None:
            return
        if self._stable_due_ms is None:
            from trackpilot.board.bootguard import STABLE_MS

            self._stable_due_ms = ticks_add(t, STABLE_MS)
        elif ticks_diff(t, self._stable_due_ms) >= 0:
            cb = self.on_stable
            self.on_stable = None
            cb()
            self.event("BOOT", "running stably: boot-loop count cleared")

    def dead_tasks(self, t):
        # input-driven tasks only beat when bytes arrive; they are checked against their data
        out = []
        for name in ("inputs", "logger", "pilot", "motor", "telemetry"):
            last = self.alive.get(name)
            if last is None or ticks_diff(t, last) > 5000:
                out.append(name)
        return out

    async def run(self):
        t = self.clock()
        self.runs = getattr(self, "runs", 0) + 1
        cause = self.reset_cause if self.runs == 1 else "restart after maintenance (no reset)"
        self.log.open_session(VERSION, self.cfg_hash(), self.core.track_id, cause, t)
        self.event("BOOT", "trackpilot %s, %s, mode %s (never engages by itself)" % (
            VERSION, cause, M.MODE_NAMES[self.core.mm.mode]))
        for p in self.cfg_problems:
            self.event("CONFIG", p)
        for coro in (
            self.task_gnss(),
            self.task_seatalk_rx(),
            self.task_seatalk_tx(),
            self.task_pilot(),
            self.task_motor(),
            self.task_wind(),
            self.task_inputs(),
            self.task_logger(),
            self.task_telemetry(),
            self.task_supervisor(),
        ):
            if coro is not None:
                asyncio.create_task(coro)
        self.ntrip_task = None
        self.ntrip_restarts = 0
        if getattr(self.w, "wifi", None) is not None:
            asyncio.create_task(self.task_wifi())  # starts NTRIP once the link is up
        elif self.cfg["ntrip"]["enabled"]:
            self.start_ntrip()
        await self.stop_event.wait()
        self.event("STOP", "application stopped")
        self.log.close()

    def cfg_hash(self):
        """An id of the configuration for the log header, one setting at a time (a JSON dump of
        the whole configuration was the largest allocation at start-up)."""
        h = 0
        for sec in sorted(self.cfg):
            body = self.cfg[sec]
            for key in sorted(body):
                for b in ("%s.%s=%r;" % (sec, key, body[key])).encode():
                    h = (h * 31 + b) & 0xFFFFFFFF
        return h
