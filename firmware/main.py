"""main.py on the ESP32: import and start the app, catching and logging exceptions.

Skip the app for a plain REPL: hold the STANDBY button (GPIO 11, SKIP_APP_PIN) while pressing
reset or powering up. Read before any file, so a config or module that crashes cannot hide it. Not
the BOOT button: GPIO 0 is a strapping pin, held at power-up it enters the ROM download mode
(docs/WIRING.md). A boot that crashes resets the board, and the boot-loop guard
(trackpilot/board/bootguard.py) skips the app after two such boots in a row. The app always starts in
STANDBY and never engages by itself.
"""
import sys

import machine

SKIP_APP_PIN = 11  # the STANDBY button, active low; fixed here, not in the config


def _skip_requested(pin_no=SKIP_APP_PIN):
    try:
        pin = machine.Pin(pin_no, machine.Pin.IN, machine.Pin.PULL_UP)
        return pin.value() == 0
    except Exception:
        return False


def _append(path, text=None, exc=None):
    try:
        with open(path, "a") as f:
            if text:
                f.write(text + "\n")
            if exc is not None:
                sys.print_exception(exc, f)
    except Exception:
        pass


def _say(text):
    print("trackpilot: " + text)
    _append("/log/boot.txt", text)


def run(guard, note=""):
    from trackpilot import config

    cfg, problems = config.load("/config.json")
    from trackpilot.board import maint
    from trackpilot.app import App
    from trackpilot.board.wiring_esp32 import Wiring

    wiring = Wiring(cfg)
    cause = wiring.reset_cause()
    if note:
        cause += "; " + note
    app = App(wiring, cfg, problems, reset_cause=cause)
    app.on_stable = guard.mark_stable  # the supervisor calls it once the app has run stably
    app.load_track("/tracks/active.csv")
    # Runs the app; in STANDBY a host's Ctrl-C (mpremote) enters the maintenance state for
    # transfers (the watchdog stays fed, the state ends by itself, no reset): maint.py.
    maint.supervise(app, feed=wiring.feed_watchdog, track_path="/tracks/active.csv",
                    timer_factory=maint.esp32_timer)


def main():
    guard = None
    try:
        if _skip_requested():
            _say("skip-app button held, REPL only")
            return
        from trackpilot.board.bootguard import BootGuard

        guard = BootGuard(machine.RTC().memory)
        run_app, note = guard.on_boot()
        if note:
            _say(note)
        if run_app:
            run(guard, note)
    except KeyboardInterrupt:
        print("trackpilot: interrupted")
        if guard is not None:
            guard.clear()  # a person at the console: not a failed boot
    except Exception as e:
        sys.print_exception(e)
        _append("/log/crash.txt", exc=e)
        if guard is not None:
            machine.reset()  # counted: STANDBY again, or the REPL after MAX_FAILED such boots
        # without the guard (it failed itself) stay in the REPL rather than risk a loop


main()
