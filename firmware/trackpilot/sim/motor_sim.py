"""A simulated motor controller that speaks trackpilot's placeholder motor frame (motor.py).

Pure Python, imports under MicroPython and CPython, so the host simulator and the tests use the
same device. Bytes in -> reply bytes out; time is injected. Not a model of the SLS60-240's
protocol (which is not public), only of the behaviour the link needs: a first-order RPM lag,
battery sag under load and a slow drain, optional silence (link loss).

Usage:
    dev = MotorSim(fmt="ascii", rpm_tau_s=1.5)
    replies = dev.feed(b"S800\\r", t_ms)   # one reply per valid setpoint frame (b"" if silent)
    dev.step(t_ms)                         # advance the model (feed() also does)
    dev.rpm, dev.batt_mv                   # state
"""
from trackpilot.compat import ticks_diff
from trackpilot.devices import motor as m


class MotorSim:
    def __init__(self, fmt=m.FMT_ASCII, rpm_tau_s=1.5, rpm_max=1500, batt_mv_full=51000,
                 sag_mv_per_krpm=2500, drain_mv_per_krpm_h=2000, failsafe_ms=2000, reply=True):
        if isinstance(fmt, str):
            fmt = m.FMT_BINARY if fmt == "binary" else m.FMT_ASCII
        self.fmt = fmt
        self.rpm_tau_s = rpm_tau_s
        self.rpm_max = rpm_max
        self.open_mv = float(batt_mv_full)  # open-circuit voltage, drains with use
        self.sag_mv_per_krpm = sag_mv_per_krpm
        self.drain_mv_per_krpm_h = drain_mv_per_krpm_h
        self.failsafe_ms = failsafe_ms  # no valid frame for this long -> setpoint 0
        self.reply = reply  # False: the device stays silent (a link without replies, or lost)
        self._parser = m.FrameParser(fmt)
        self.setpoint = 0
        self.rpm = 0.0
        self.batt_mv = int(self.open_mv)
        self.status = 0  # bit 0: failsafe active (no setpoint lately)
        self._t = None
        self._last_frame = None
        self.frames = 0

    def step(self, t_ms):
        if self._t is None:
            self._t = t_ms
            return
        dt = ticks_diff(t_ms, self._t) / 1000.0
        if dt <= 0:
            return
        self._t = t_ms
        if self._last_frame is not None and ticks_diff(t_ms, self._last_frame) > self.failsafe_ms:
            self.setpoint = 0
            self.status |= 1
        a = dt / (self.rpm_tau_s + dt)  # first-order lag, stable for any dt
        self.rpm += (self.setpoint - self.rpm) * a
        load = abs(self.rpm) / 1000.0
        self.open_mv -= self.drain_mv_per_krpm_h * load * dt / 3600.0
        self.batt_mv = int(self.open_mv - self.sag_mv_per_krpm * load)

    def feed(self, data, t_ms):
        """Frames from the firmware; returns the reply bytes (may be b"")."""
        self.step(t_ms)
        out = b""
        for b in data:
            r = self._parser.feed_byte(b)
            if r is None or r[0] != "S":
                continue
            self.frames += 1
            self._last_frame = t_ms
            self.status &= ~1
            self.setpoint = max(-self.rpm_max, min(self.rpm_max, r[1]))
            if self.reply:
                out += m.encode_reply(int(self.rpm), self.batt_mv, self.status, self.fmt)
        return out
