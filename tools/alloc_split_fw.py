# Firmware entry for tools/alloc_split.py (f32 builds only: gcinfo.allocated()). Wraps the
# functions that allocate per epoch with a counter of the bytes allocated during each call (freed
# or not: what gc.threshold counts), runs sim_main, and prints the sums on stderr. The wrappers
# allocate a little themselves (counted in the total, not in the rows).
import sys

import gcinfo
from trackpilot import app as appmod
from trackpilot.core import autopilot
from trackpilot.record import logger
from trackpilot.sim import simio, wiring_sim

ACC = {}


def wrap(cls, name, key):
    f = getattr(cls, name)

    def counted(*a):
        b = gcinfo.allocated()
        try:
            return f(*a)
        finally:
            ACC[key] = ACC.get(key, 0) + gcinfo.allocated() - b

    setattr(cls, name, counted)


ROWS = (
    (appmod.App, "on_gnss_bytes", "firmware: GNSS parse + control step (core.on_fix, log record)"),
    (appmod.App, "on_seatalk_bytes", "firmware: SeaTalk receive"),
    (autopilot.Autopilot, "seatalk_tx", "firmware: SeaTalk transmit (core.seatalk_tx)"),
    (autopilot.Autopilot, "on_seatalk_tx_done", "firmware: SeaTalk transmit (core.on_seatalk_tx_done)"),
    (autopilot.Autopilot, "pilot_next_due_ms", "firmware: SeaTalk transmit (core.pilot_next_due_ms)"),
    (autopilot.Autopilot, "on_pilot_tick", "firmware: pilot timers"),
    (autopilot.Autopilot, "motor_tick", "firmware: motor"),
    (autopilot.Autopilot, "on_estop", "firmware: inputs (e-stop)"),
    (appmod.App, "nmea_sentences", "firmware: telemetry (NMEA sentences)"),
    (logger.Logger, "tick", "firmware: log writer"),
    (wiring_sim.Wiring, "show", "wiring: LEDs and display"),
    (wiring_sim.Wiring, "poll_commands", "wiring: buttons and remote"),
    (wiring_sim.Wiring, "send_status", "wiring: telemetry status"),
    (wiring_sim.Wiring, "send_nmea", "wiring: telemetry NMEA"),
    (simio.SimStream, "read", "UART reads (simulated)"),
    (simio.SimStream, "readinto", "UART reads (simulated)"),
    (simio.SimStream, "write", "UART writes (simulated)"),
    (simio.SimLink, "report", "simulator adapter only (simio report)"),
    (simio.SimLink, "read_step", "simulator adapter only (simio read_step)"),
)
for cls, name, key in ROWS:
    if hasattr(cls, name):
        wrap(cls, name, key)

T0 = gcinfo.allocated()
import sim_main  # noqa: E402,F401  (runs the firmware)

sys.stderr.write("alloc_split: total %d\n" % (gcinfo.allocated() - T0))
for key in ACC:
    sys.stderr.write("alloc_split: %s = %d\n" % (key, ACC[key]))
