"""The decision core with every input written down (simulation only): replay (tools/replay_core.py)
feeds the same inputs, in the same order and at the same times, to a fresh core and checks that
it decides the same: every event, every control record (keystrokes, RPM setpoint, mode) and every
byte put on the SeaTalk bus.

One line per call into the core, "<code> <t_ms> <args>": floats as the hex of their 8-byte IEEE
value (exact), bytes as hex, None as "-". The flight log cannot carry this (about 60 calls a
second); the simulator writes it with `sim_main --journal PATH`.

Usage:
    app = App(wiring, cfg, problems, core_class=journal.journaling(open(path, "w")))
"""
import struct
from binascii import hexlify

from trackpilot.core.autopilot import Autopilot


def fnum(x):
    """A float (or None) exactly, as text."""
    return "-" if x is None else hexlify(struct.pack("<d", x)).decode()


def hexb(mv, n):
    return hexlify(bytes(mv[:n])).decode() if n else "-"


def fix_text(fix):
    return "%d %d %d %d %d %d %d %d %d %s %d %s %s %d %s %s" % (
        fix.t_ms, fix.itow_ms, 1 if fix.pos_valid else 0, fix.lat_e7, fix.lon_e7, fix.lat_hp,
        fix.lon_hp, fix.rtk, fix.num_sv, fnum(fix.h_acc_m), 1 if fix.heading_valid else 0,
        fnum(fix.heading_deg), fnum(fix.heading_acc_deg), 1 if fix.vel_valid else 0,
        fnum(fix.sog_mps), fnum(fix.cog_deg))


def journaling(out):
    """An Autopilot class whose entries write their inputs (and the bus actions they return) to
    the open text file `out` before deciding."""

    class JournalingAutopilot(Autopilot):
        def _w(self, line):
            out.write(line)
            out.write("\n")

        def on_fix(self, t_ms, interval_ms, corr_age_s):
            self._w("F %d %d %s %s" % (t_ms, interval_ms, fnum(corr_age_s), fix_text(self.fix)))
            Autopilot.on_fix(self, t_ms, interval_ms, corr_age_s)

        def on_gnss_watch(self, t_ms, interval_ms, corr_age_s):
            self._w("G %d %d %s" % (t_ms, interval_ms, fnum(corr_age_s)))
            Autopilot.on_gnss_watch(self, t_ms, interval_ms, corr_age_s)

        def on_seatalk_rx(self, buf, n, t):
            self._w("R %d %s" % (t, hexb(buf, n)))
            Autopilot.on_seatalk_rx(self, buf, n, t)

        def seatalk_tx(self, t):
            act = Autopilot.seatalk_tx(self, t)
            self._w("X %d %s" % (t, " ".join(str(a) for a in act)))
            return act

        def on_seatalk_tx_done(self, t, now_ms):
            self._w("D %d %d" % (t, now_ms))
            Autopilot.on_seatalk_tx_done(self, t, now_ms)

        def on_pilot_tick(self, t):
            self._w("P %d" % t)
            Autopilot.on_pilot_tick(self, t)

        def on_motor_rx(self, mv, n, t):
            self._w("M %d %s" % (t, hexb(mv, n)))
            Autopilot.on_motor_rx(self, mv, n, t)

        def motor_tick(self, t):
            frame = Autopilot.motor_tick(self, t)
            self._w("K %d %s" % (t, hexb(frame, len(frame)) if frame else "-"))
            return frame

        def on_wind_rx(self, mv, n, t):
            self._w("W %d %s" % (t, hexb(mv, n)))
            Autopilot.on_wind_rx(self, mv, n, t)

        def on_estop(self, active, t):
            self._w("E %d %d" % (t, 1 if active else 0))
            Autopilot.on_estop(self, active, t)

        def on_key(self, name, source, t, corr_age_s):
            self._w("C %d %s %s %s" % (t, name, source, fnum(corr_age_s)))
            Autopilot.on_key(self, name, source, t, corr_age_s)

        def set_track(self, new, new_id, prog, t_ms):
            self._w("T %d %s" % (t_ms, new_id))
            Autopilot.set_track(self, new, new_id, prog, t_ms)

        def restore_state(self, st, t_ms):
            self._w("S %d %s %d %s" % (t_ms, st.get("track_id", "-") or "-", int(st.get("leg", 0)),
                                       st.get("mode", "?")))
            Autopilot.restore_state(self, st, t_ms)

        def settle(self, t_ms):
            self._w("N %d" % t_ms)
            Autopilot.settle(self, t_ms)

    return JournalingAutopilot
