"""Boot-loop guard: a count of boots that never ran stably, kept in RTC memory.

A crash at boot (a bad file, a broken module, a MemoryError) ends in machine.reset() or the
watchdog, and the next boot would crash the same way, for ever. So each boot counts itself in RTC
memory (it survives resets and the watchdog, not a power cycle) before the app starts, and the app
clears the count once it has run stably (STABLE_MS with every task alive). With MAX_FAILED boots
in a row that never got there, the next boot skips the app and leaves the REPL (the count is then
cleared, so a reset tries again).

Functional core: fed the RTC memory accessor (machine.RTC().memory, or a fake in tests), no
`machine` import.

Usage (main.py):
    guard = BootGuard(machine.RTC().memory)
    run_app, note = guard.on_boot()    # note: '' or what happened, for the console and the log
    ...
    app.on_stable = guard.mark_stable  # called by the app's supervisor
"""

MAGIC = b"TPBG"
MAX_FAILED = 2  # boots in a row without reaching STABLE_MS; then the app is skipped once
STABLE_MS = 60000  # running this long with all tasks alive clears the count


class BootGuard:
    def __init__(self, memory, max_failed=MAX_FAILED):
        """memory(): the RTC memory's bytes; memory(data): store them (machine.RTC().memory)."""
        self._memory = memory
        self.max_failed = max_failed
        self.failed = 0  # boots before this one that did not run stably

    def _read(self):
        try:
            data = bytes(self._memory())
        except Exception:  # a board without RTC memory: no guard, but no crash either
            return 0
        if len(data) >= 5 and data[:4] == MAGIC:
            return data[4]
        return 0  # power-on: RTC memory blank or someone else's

    def _write(self, count):
        try:
            self._memory(MAGIC + bytes((min(count, 255),)))
        except Exception:
            pass

    def on_boot(self):
        """Count this boot. Returns (run_app, note)."""
        self.failed = self._read()
        if self.failed >= self.max_failed:
            self._write(0)  # skip once; a reset (after a fix) tries the app again
            return False, ("%d boots in a row ended before the app ran stably: app skipped, REPL "
                           "only (reset to try again)" % self.failed)
        self._write(self.failed + 1)
        if self.failed:
            return True, "%d earlier boot(s) ended before the app ran stably" % self.failed
        return True, ""

    def mark_stable(self):
        """The app has run stably: the next reset is a fresh start."""
        self.failed = 0
        self._write(0)

    def clear(self):
        self._write(0)
