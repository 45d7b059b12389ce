"""The simulated motor controller on the RS232 link.

It is `firmware/trackpilot/motor_sim.py` (written with the firmware's motor link, importable under
CPython): bytes in -> replies out, and the RPM it runs at, which drives the boat's surge model.
This adapter adds the link-loss fault (the cable is cut: no replies, setpoints never arrive, so the
controller's own failsafe stops the motor after its timeout) and reply timing.
"""
import sys

from ..mpy import FIRMWARE_DIR


def _load_motor_sim():
    if str(FIRMWARE_DIR) not in sys.path:
        sys.path.insert(0, str(FIRMWARE_DIR))
    from trackpilot import motor_sim  # noqa: E402

    return motor_sim


class MotorDevice:
    def __init__(self, fw_motor_cfg, rng):
        ms = _load_motor_sim()
        self.dev = ms.MotorSim(fmt=fw_motor_cfg["frame"], rpm_max=fw_motor_cfg["rpm_max"])
        self.rng = rng
        self.link_lost = False
        self.frames_in = 0
        self.setpoints = []  # (t_ms, rpm) at each change of the received setpoint

    @property
    def rpm(self):
        return self.dev.rpm

    def feed(self, t_ms, data):
        """Bytes from the firmware at t_ms -> (delivery_t_ms, reply bytes) or None."""
        if self.link_lost:
            return None
        out = self.dev.feed(data, t_ms)
        self.frames_in = self.dev.frames
        if not self.setpoints or self.setpoints[-1][1] != self.dev.setpoint:
            self.setpoints.append((t_ms, self.dev.setpoint))
        if not out:
            return None
        return t_ms + 2 + len(out) * 10 * 1000 // 9600, bytes(out)

    def advance(self, t_ms):
        self.dev.step(t_ms)
