"""main.py on the ESP32: import and start the app, catching and logging exceptions.

Hold the skip-app button (BOOT, GPIO0 by default) while powering up to get a plain REPL: the ESP32
has no safe mode of its own. The app always starts in STANDBY and never engages by itself.
"""
import sys

import machine


def _skip_requested(cfg):
    pin_no = cfg["wiring"]["skip_app_pin"]
    if pin_no < 0:
        return False
    pin = machine.Pin(pin_no, machine.Pin.IN, machine.Pin.PULL_UP)
    return pin.value() == 0


def _crash_log(e):
    try:
        with open("/log/crash.txt", "a") as f:
            sys.print_exception(e, f)
    except OSError:
        pass


def run():
    from trackpilot import config

    cfg, problems = config.load("/config.json")
    if _skip_requested(cfg):
        print("trackpilot: skip-app button held, REPL only")
        return
    from trackpilot import maint
    from trackpilot.app import App
    from trackpilot.wiring_esp32 import Wiring

    wiring = Wiring(cfg)
    app = App(wiring, cfg, problems, reset_cause=wiring.reset_cause())
    app.load_track("/tracks/active.csv")
    # Runs the app; in STANDBY a host's Ctrl-C (mpremote) enters the maintenance state for
    # transfers (the watchdog stays fed, the state ends by itself, no reset): maint.py.
    maint.supervise(app, feed=wiring.feed_watchdog, track_path="/tracks/active.csv",
                    timer_factory=maint.esp32_timer)


try:
    run()
except KeyboardInterrupt:
    print("trackpilot: interrupted")
except Exception as e:
    sys.print_exception(e)
    _crash_log(e)
    machine.reset()  # come back in STANDBY: the app never engages by itself after a reset
