# The boot-loop guard (bootguard.py) and main.py's boot path with a fake `machine`: a config that
# crashes config.load resets the board at most twice, the third boot leaves the REPL; the skip
# button is read before any file.
import sys

import tpassert as t
from trackpilot import bootguard, config


class FakeRtcMemory:
    def __init__(self):
        self.data = b""
        self.writes = 0

    def __call__(self, data=None):
        if data is None:
            return self.data
        self.data = bytes(data)
        self.writes += 1


def test_counts_skips_and_clears():
    mem = FakeRtcMemory()
    g = bootguard.BootGuard(mem)
    t.eq(g.on_boot(), (True, ""))  # power-on: blank memory
    ok, note = bootguard.BootGuard(mem).on_boot()  # that boot crashed
    t.true(ok and "1 earlier boot" in note, note)
    ok, note = bootguard.BootGuard(mem).on_boot()  # two in a row crashed
    t.true(not ok and "app skipped" in note, note)
    t.eq(bootguard.BootGuard(mem).on_boot(), (True, ""))  # the reset after the skip tries again
    g = bootguard.BootGuard(mem)
    g.on_boot()
    g.mark_stable()
    t.eq(bootguard.BootGuard(mem).on_boot(), (True, ""))  # ran stably: a fresh start


def test_foreign_or_broken_memory():
    mem = FakeRtcMemory()
    mem.data = b"\xff" * 16  # someone else's data
    t.eq(bootguard.BootGuard(mem).on_boot(), (True, ""))

    def broken(data=None):
        raise OSError(5)

    t.eq(bootguard.BootGuard(broken).on_boot(), (True, ""))  # no guard, but no crash


class FakeMachine:
    """Just what main.py touches before the app: Pin, RTC().memory, reset()."""

    def __init__(self, mem, held=False):
        fm = self
        self.resets = 0
        self.pins_read = []

        class Pin:
            IN = 1
            PULL_UP = 2

            def __init__(self, no, mode=None, pull=None):
                self.no = no

            def value(self):
                fm.pins_read.append(self.no)
                return 0 if held else 1

        class RTC:
            def memory(self, data=None):
                return mem(data)

        self.Pin = Pin
        self.RTC = RTC

    def reset(self):
        self.resets += 1


def _boot(mem, held=False):
    """One boot of firmware/main.py; config.load crashes (a Latin-1 byte in the config)."""
    fm = FakeMachine(mem, held)
    sys.modules["machine"] = fm
    calls = []
    real = config.load

    def crashing_load(path):
        calls.append(path)
        raise UnicodeError("invalid utf-8")

    config.load = crashing_load
    try:
        with open("firmware/main.py") as f:
            exec(f.read(), {"__name__": "__main__"})
    finally:
        config.load = real
        del sys.modules["machine"]
    return fm, calls


def test_main_crash_at_boot_cannot_loop():
    mem = FakeRtcMemory()
    fm, calls = _boot(mem)
    t.eq((fm.resets, len(calls)), (1, 1))  # crashed, reset (counted)
    fm, calls = _boot(mem)
    t.eq((fm.resets, len(calls)), (1, 1))
    fm, calls = _boot(mem)
    t.eq((fm.resets, len(calls)), (0, 0))  # skipped: the REPL, no reset, config not read
    fm, calls = _boot(mem)
    t.eq((fm.resets, len(calls)), (1, 1))  # the reset after a fix tries again


def test_skip_button_needs_nothing_but_the_pin():
    mem = FakeRtcMemory()
    fm, calls = _boot(mem, held=True)
    t.eq((fm.resets, len(calls)), (0, 0))
    t.eq(fm.pins_read, [11])  # the STANDBY button, never GPIO 0 (a strapping pin)
    t.eq(mem.writes, 0)


def test_app_reports_stable_once_after_a_minute():
    from test_app_track_load import HAVE_ASYNCIO, _app

    if not HAVE_ASYNCIO:
        print("skipped: no asyncio")
        return
    app, w = _app()
    calls = []
    app.on_stable = lambda: calls.append(1)
    app._check_stable(1000)
    app._check_stable(1000 + bootguard.STABLE_MS - 1)
    t.eq(calls, [])
    app._check_stable(1000 + bootguard.STABLE_MS)
    app._check_stable(1000 + 2 * bootguard.STABLE_MS)
    t.eq(calls, [1])
    t.true("running stably" in w.lines[-1], w.lines[-1])
