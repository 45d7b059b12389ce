"""Maintenance state: file transfers (mpremote) on a running board, without a surprise reset.

Why: mpremote's first act is Ctrl-C then Ctrl-A (raw REPL). On a board whose app runs a watchdog
that cannot be stopped, a plain Ctrl-C would end the app at a random line and the watchdog would
reset the board 8 s later, possibly in the middle of a transfer. So:

  * While the app runs, Ctrl-C is NOT the interrupt character (`micropython.kbd_intr(-1)`): the
    console guard (a task beside the app) reads the console byte by byte and sees Ctrl-C itself.
  * Ctrl-C in STANDBY: the guard logs the request and stops the app cleanly (log flushed and
    closed: steering, pilot and motor work all pause), and `supervise()` serves a small raw REPL
    written in Python (`Server`), which speaks the subset of the raw REPL protocol mpremote uses
    (raw mode, raw-paste mode, exec with stdout/stderr framing). mpremote cannot tell it from the
    C REPL. The watchdog is fed by the server loop and by a timer during long commands.
  * Ctrl-C in any other mode (AUTO, ALARM, E-STOP): refused; the guard prints one line
    `trackpilot: maintenance refused: <reason>` and the app goes on. The input is discarded.
  * The state ends when the host calls `trackpilot.board.maint.resume()`, after `idle_s` without a byte
    from the host, or at `limit_s` after entry, whichever comes first. Then the app restarts
    WITHOUT a reset, in STANDBY, and reloads the active track (a new track is picked up here).
  * A soft reset asked for by the host (Ctrl-D on an empty raw-REPL line, what mpremote does
    without `resume`) is answered as mpremote expects but NOT performed: exec globals are cleared
    and the board stays in maintenance.

Host side (docs/DEVICE.md): `trackpilot upload/pull/deploy` probe with Ctrl-B Ctrl-C and read the
guard's answer, then run `mpremote connect PORT resume ...`, then
`mpremote connect PORT resume exec "import trackpilot.board.maint as m; m.resume()"`.

Usage (main.py; the same loop runs the test harness under the unix port):
    from trackpilot.board import maint
    maint.supervise(app, feed=wiring.feed_watchdog, track_path="/tracks/active.csv",
                    timer_factory=maint.esp32_timer)
The pure logic is `Gate` (tested in tests/mpy/test_maint.py); `Console`, `Server`, `guard` and
`supervise` are the thin I/O shell.
"""
import sys

from trackpilot.compat import ticks_add, ticks_diff

try:
    import micropython
except ImportError:  # pragma: no cover (CPython)
    micropython = None

IDLE = 0
ACTIVE = 1
STATE_NAMES = ("IDLE", "ACTIVE")

IDLE_S = 120  # no byte from the host for this long: the host is gone, resume the app
LIMIT_S = 900  # hard limit after entry, whatever the host does (a 6 MB pull takes ~2 min)
GRACE_MS = 30000  # a command still running this long after the limit: stop feeding the WDT

REFUSED_PREFIX = "trackpilot: maintenance refused: "
ENTERED_PREFIX = "trackpilot: maintenance"  # the host's probe looks for this text

_CTRL_A = 1
_CTRL_B = 2
_CTRL_C = 3
_CTRL_D = 4
_CTRL_E = 5


class Gate:
    """Pure logic of the maintenance state: may it start, when does it end, why.

    All times are ticks in ms (compared only with ticks_diff, so the 2**30 wrap is harmless)."""

    def __init__(self, idle_s=IDLE_S, limit_s=LIMIT_S):
        self.idle_ms = int(idle_s * 1000)
        self.limit_ms = int(limit_s * 1000)
        self.state = IDLE
        self.entered_ms = 0
        self.last_ms = 0  # last byte from the host
        self.end_reason = ""
        self.entries = 0

    def request(self, mode_name, t_ms, estop_latched=False):
        """A host asks for maintenance while the app is in `mode_name`. Returns (ok, reason);
        on ok the state is ACTIVE."""
        if self.state == ACTIVE:
            return True, "already in maintenance"
        if estop_latched:
            return False, "E-stop latched: clear it first"
        if mode_name != "STANDBY":
            return False, "mode %s: put the pilot in STANDBY first" % mode_name
        self.state = ACTIVE
        self.entered_ms = t_ms
        self.last_ms = t_ms
        self.end_reason = ""
        self.entries += 1
        return True, "entered"

    def activity(self, t_ms):
        """A byte from the host: pushes the idle deadline (never the hard limit)."""
        self.last_ms = t_ms

    def deadline_ms(self):
        """Tick at which the state ends by itself (the earlier of idle and limit)."""
        idle_end = ticks_add(self.last_ms, self.idle_ms)
        limit_end = ticks_add(self.entered_ms, self.limit_ms)
        return idle_end if ticks_diff(idle_end, limit_end) < 0 else limit_end

    def remaining_ms(self, t_ms):
        if self.state != ACTIVE:
            return 0
        return max(0, ticks_diff(self.deadline_ms(), t_ms))

    def expired(self, t_ms):
        """None while it may go on, else the reason it ends now."""
        if self.state != ACTIVE:
            return None
        if ticks_diff(t_ms, ticks_add(self.entered_ms, self.limit_ms)) >= 0:
            return "time limit %d s reached" % (self.limit_ms // 1000)
        if ticks_diff(t_ms, ticks_add(self.last_ms, self.idle_ms)) >= 0:
            return "no host activity for %d s" % (self.idle_ms // 1000)
        return None

    def may_feed(self, t_ms):
        """The watchdog timer feeds only while maintenance is active and not long past its limit:
        a command that hangs beyond limit + grace ends in a watchdog reset (STANDBY after reset)."""
        if self.state != ACTIVE:
            return False
        return ticks_diff(t_ms, ticks_add(self.entered_ms, self.limit_ms + GRACE_MS)) < 0

    def end(self, reason):
        if self.state == ACTIVE:
            self.state = IDLE
            self.end_reason = reason
        return self.end_reason


# ---------------------------------------------------------------------- the thin I/O shell
class Console:
    """The REPL console (USB CDC / UART0 on the ESP32, the pty under the unix port), byte-wise."""

    def __init__(self, stdin=None, stdout=None):
        import select

        self.inp = stdin or getattr(sys.stdin, "buffer", sys.stdin)
        self.out = stdout or getattr(sys.stdout, "buffer", sys.stdout)
        self.poller = select.poll()
        self.poller.register(self.inp, select.POLLIN)

    def read_byte(self, timeout_ms):
        """One byte as an int, or None after timeout_ms (0: do not wait)."""
        if not self.poller.poll(timeout_ms):
            return None
        b = self.inp.read(1)
        if not b:
            return None
        return b if isinstance(b, int) else ord(b)

    def write(self, data):
        if isinstance(data, str):
            data = data.encode()
        try:
            self.out.write(data)
        except TypeError:  # a text-only stdout
            self.out.write(data.decode())


def _set_kbd_intr(ch):
    if micropython is not None and hasattr(micropython, "kbd_intr"):
        micropython.kbd_intr(ch)


_active = None  # the running Server, for resume()


def resume():
    """Called by the host (over the raw REPL): end maintenance and restart the app."""
    if _active is None:
        print("trackpilot: not in maintenance")
        return False
    _active.resume_requested = True
    return True


def status():
    """One line for the host: state and remaining seconds."""
    if _active is None:
        return "IDLE"
    g = _active.gate
    return "%s %d" % (STATE_NAMES[g.state], g.remaining_ms(_active.clock()) // 1000)


class Server:
    """A raw REPL in Python (what mpremote needs), serving until resume() or the deadline.

    Protocol (py/pyexec.c): Ctrl-A enters raw mode and prints the banner and '>'; code ends with
    Ctrl-D and is answered 'OK', its stdout, Ctrl-D, its exception text, Ctrl-D, then '>'.
    Raw-paste: Ctrl-E 'A' Ctrl-A -> 'R' 0x01 + window size (u16 LE); the device sends 0x01 each
    time it has taken one window of bytes; Ctrl-D ends (acknowledged with Ctrl-D), then stdout,
    Ctrl-D, stderr, Ctrl-D. Ctrl-B leaves raw mode (mpremote sends it on disconnect)."""

    BANNER = b"raw REPL; CTRL-B to exit\r\n"
    WINDOW = 128  # raw-paste flow-control window in bytes

    def __init__(self, console, gate, clock, feed=None):
        self.c = console
        self.gate = gate
        self.clock = clock
        self.feed = feed or (lambda: None)
        self.resume_requested = False
        self.globals = {"__name__": "__main__"}
        self.commands = 0
        self.raw = False

    def _byte(self, timeout_ms=200):
        """Next byte from the host; feeds the watchdog while waiting; None on timeout."""
        self.feed()
        b = self.c.read_byte(timeout_ms)
        if b is not None:
            self.gate.activity(self.clock())
        return b

    def _friendly_prompt(self):
        left_s = self.gate.remaining_ms(self.clock()) // 1000
        self.c.write("\r\n%s: %d s left; Ctrl-A raw REPL for mpremote; "
                     "trackpilot.board.maint.resume() ends it\r\n" % (ENTERED_PREFIX, left_s))

    def serve(self):
        """Returns the reason maintenance ended."""
        global _active
        _active = self
        _set_kbd_intr(-1)  # bytes, not interrupts, while reading the host's input
        try:
            self._friendly_prompt()
            line = bytearray()
            while True:
                if self.resume_requested:
                    return "resumed by the host"
                why = self.gate.expired(self.clock())
                if why:
                    return why
                b = self._byte()
                if b is None:
                    continue
                if b == _CTRL_A:
                    self.raw = True
                    line = bytearray()
                    self.c.write(self.BANNER + b">")
                elif b == _CTRL_B:
                    if self.raw:
                        self.raw = False
                        self._friendly_prompt()
                elif b == _CTRL_C:
                    line = bytearray()
                    if not self.raw:
                        self._friendly_prompt()
                elif not self.raw:
                    pass  # no line editor here: the friendly REPL is the C one (skip-app button)
                elif b == _CTRL_E and not line:
                    if self._paste_request():
                        code = self._paste_body()
                        if code is not None:
                            self._run(code, b"")
                        self.c.write(b">")
                elif b == _CTRL_D:
                    if not line:
                        self._fake_soft_reset()
                    else:
                        self._run(bytes(line), b"OK")
                        line = bytearray()
                        self.c.write(b">")
                else:
                    line.append(b)
        finally:
            _active = None
            _set_kbd_intr(-1)

    def _paste_request(self):
        # after Ctrl-E the host sends 'A' Ctrl-A
        if self._byte(1000) != ord("A") or self._byte(1000) != _CTRL_A:
            self.c.write(b"R\x00")  # understood, not supported: mpremote falls back to raw mode
            return False
        w = self.WINDOW
        self.c.write(bytes((ord("R"), 1, w & 0xFF, w >> 8)))
        return True

    def _paste_body(self):
        code = bytearray()
        remain = self.WINDOW
        while True:
            b = self._byte(5000)
            if b is None:
                if self.gate.expired(self.clock()):
                    return None
                continue
            if b == _CTRL_D or b == _CTRL_C:
                self.c.write(b"\x04")
                return None if b == _CTRL_C else bytes(code)
            code.append(b)
            remain -= 1
            if remain == 0:
                self.c.write(b"\x01")
                remain = self.WINDOW

    def _fake_soft_reset(self):
        # mpremote without `resume` asks for a soft reset; a reset is not what a transfer may do:
        # give it a fresh namespace and the answer it waits for, and stay in maintenance.
        self.globals = {"__name__": "__main__"}
        self.c.write(b"OK\r\nsoft reboot\r\n" + self.BANNER + b">")

    def _run(self, code, ack):
        self.commands += 1
        if ack:
            self.c.write(ack)
        err = None
        _set_kbd_intr(_CTRL_C)  # a runaway command can be interrupted, as in the C REPL
        try:
            exec(code, self.globals)
        except BaseException as e:  # report everything to the host, like the C REPL does
            err = e
        finally:
            _set_kbd_intr(-1)
        self.c.write(b"\x04")
        if err is not None:
            import io

            text = io.StringIO()  # print_exception needs a native stream
            # the esp32 stubs (1.29) lack StringIO as a stream and its getvalue(); MicroPython has both
            sys.print_exception(err, text)  # pyright: ignore[reportArgumentType]
            self.c.write(text.getvalue())  # pyright: ignore[reportAttributeAccessIssue]
        self.c.write(b"\x04")
        self.gate.activity(self.clock())


async def guard(app, gate, console, note=None, track_path=None):
    """Beside the app: read the console; Ctrl-C asks for maintenance (granted only in STANDBY).

    Reads one byte per poll so that the bytes after Ctrl-C stay for the server. After a
    maintenance it logs how it ended and reloads the track, inside the new log session."""
    import asyncio

    from trackpilot.core import modes as M

    if note:
        app.event("MAINT", note)
    if track_path:
        app.load_track(track_path)  # STANDBY here by construction: a new track is picked up
    while True:
        b = console.read_byte(0)
        if b is None:
            await asyncio.sleep_ms(50)
            continue
        if b != _CTRL_C:
            continue  # mpremote's Ctrl-B on disconnect, stray input: discarded
        t = app.clock()
        mm = app.mm
        ok, why = gate.request(M.MODE_NAMES[mm.mode], t, mm.estop_latched)
        if not ok:
            app.event("MAINT", "refused: " + why)
            console.write("\r\n%s%s\r\n" % (REFUSED_PREFIX, why))
            continue
        app.event("MAINT", "entered (host request); app paused, watchdog fed for at most %d s"
                  % (gate.limit_ms // 1000))
        console.write("\r\n%s: entered\r\n" % ENTERED_PREFIX)
        app.maint_requested = True
        app.stop_event.set()  # app.run() logs STOP, closes the log and returns
        return


async def _run_with_guard(app, gate, console, note, track_path):
    import asyncio

    asyncio.create_task(guard(app, gate, console, note, track_path))
    await app.run()


TIMER_ID = 0  # ESP32 hardware timer for feeding the watchdog during maintenance (app uses none)


def esp32_timer(period_ms, callback):
    """A periodic machine.Timer (soft callback: runs between bytecodes of a long command)."""
    import machine

    t = machine.Timer(TIMER_ID)
    t.init(period=period_ms, mode=machine.Timer.PERIODIC, callback=callback)
    return t


def supervise(app, feed, track_path=None, console=None, timer_factory=None, idle_s=IDLE_S,
              limit_s=LIMIT_S, max_runs=None):
    """Run the app; serve maintenance when the guard asks for it; restart the app after it.

    feed: feeds the hardware watchdog. timer_factory(period_ms, cb): a periodic timer that keeps
    feeding it while a long command runs (None under the unix port). Returns when the app stops
    for another reason (or after max_runs runs, for tests)."""
    import asyncio

    console = console or Console()
    gate = Gate(idle_s, limit_s)
    note = None
    reload_path = None  # the first run: main.py has loaded the track already
    runs = 0
    while True:
        _set_kbd_intr(-1)
        app.maint_requested = False
        app.stop_event = asyncio.Event()
        asyncio.new_event_loop()  # the last run's tasks must not come back
        asyncio.run(_run_with_guard(app, gate, console, note, reload_path))
        runs += 1
        if not app.maint_requested:
            return "app stopped"
        clock = app.clock
        timer = None
        if timer_factory is not None:
            timer = timer_factory(1000, lambda _t: feed() if gate.may_feed(clock()) else None)
        try:
            reason = Server(console, gate, clock, feed).serve()
        finally:
            if timer is not None:
                timer.deinit()
        gate.end(reason)
        console.write("\r\n%s ended: %s; app restarting in STANDBY\r\n" % (ENTERED_PREFIX, reason))
        note = "ended: %s" % reason
        reload_path = track_path
        if max_runs is not None and runs >= max_runs:
            return reason
