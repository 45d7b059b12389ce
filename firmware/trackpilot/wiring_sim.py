"""Wiring for simulation: devices are SimStreams (pipes to the simulator, docs/SIM_PROTOCOL.md).

The ESP32 twin is `wiring_esp32.py`; the application cannot tell them apart. Inputs (E-stop,
buttons) arrive as `NAME=VALUE` lines on device 5; outputs (LEDs, buzzer, mode) leave the same way,
and the telemetry status datagram leaves on device 6.
"""
import sys

try:
    import os
except ImportError:  # pragma: no cover
    import uos as os

from trackpilot import simio
from trackpilot.stlink import Prng


class Wiring:
    def __init__(self, link, data_dir, seed=1, quiet=False):
        self.link = link
        self.ticks_ms = link.ticks_ms
        self.gnss_uart = link.stream(simio.DEV_GNSS)
        self.seatalk_uart = link.stream(simio.DEV_SEATALK)
        self.motor_uart = link.stream(simio.DEV_MOTOR)
        self.wind_uart = link.stream(simio.DEV_WIND)
        self.io = link.stream(simio.DEV_IO)
        self.telemetry = link.stream(simio.DEV_TELEMETRY)
        self.nmea_out = link.stream(simio.DEV_NMEA_OUT)
        self.input_period_ms = 100  # inputs arrive as whole, debounced presses (SIM_PROTOCOL.md)
        self.rand = Prng(seed)  # deterministic back-off: same seed, same run
        self.data_dir = data_dir
        self.log_dir = data_dir + "/log"
        self.state_path = data_dir + "/state.json"
        self.quiet = quiet
        self._estop = False
        self._cmds = []
        self._line = bytearray()
        self._outputs = {}
        self.page = 0
        self.watchdog_feeds = 0
        self.throttle_duty = 0.0
        for d in (data_dir, self.log_dir):
            try:
                os.mkdir(d)
            except OSError:
                pass

    def statvfs(self, path):
        return os.statvfs(path)

    def debug(self, msg):
        if not self.quiet:
            sys.stderr.write("[%d] %s\n" % (self.link.t_ms, msg))

    # inputs -------------------------------------------------------------
    def _read_inputs(self):
        data = self.io.read()
        if not data:
            return
        for b in data:
            if b == 10:
                line = bytes(self._line).decode()
                self._line = bytearray()
                name, _, value = line.partition("=")
                if name == "estop":
                    self._estop = value == "1"
                elif name == "button":
                    self._cmds.append((value, "HMI"))
                elif name == "remote":
                    self._cmds.append((value, "remote"))
            elif len(self._line) < 80:
                self._line.append(b)

    def estop_active(self):
        self._read_inputs()
        return self._estop

    def poll_commands(self, t_ms):
        self._read_inputs()
        cmds = self._cmds
        self._cmds = []
        return cmds

    def next_page(self):
        self.page = (self.page + 1) % 4

    # outputs ------------------------------------------------------------
    def _out(self, name, value):
        if self._outputs.get(name) != value:
            self._outputs[name] = value
            self.io.write(b"%s=%s\n" % (name, value))

    def show(self, app, t_ms):
        from trackpilot import modes as M

        mm = app.mm
        self._out("mode", mm.state_text())
        self._out("led_auto", "1" if mm.mode == M.AUTO else "0")
        self._out("led_alarm", "1" if mm.alarms else "0")
        self._out("led_gps", str(app.fix.rtk))
        self._out("alarms", str(mm.alarms))
        if app.progress is not None:
            self._out("leg", str(app.progress.leg))
            self._out("finished", "1" if app.progress.finished else "0")

    def send_status(self, app, t_ms):
        try:
            from tphmi.status import HmiStatus, status_from_app, encode_status
        except ImportError:
            return
        st = getattr(self, "_status", None)
        if st is None:  # one status kept, as the board does: its seq counts, its boat id is set
            st = self._status = HmiStatus()
            st.boat_id = app.cfg.get("hmi", {}).get("boat_id", 1)
        status_from_app(app, t_ms, st)
        st.seq = (st.seq + 1) & 0xFFFF
        self.telemetry.write(encode_status(st))

    def send_nmea(self, data):
        self.nmea_out.write(data)

    def set_throttle(self, duty):
        self.throttle_duty = duty

    def feed_watchdog(self):
        self.watchdog_feeds += 1

    def correction_age_s(self, t_ms):
        return None
