# Small portability layer so firmware modules also import under CPython (host tools, tests).
try:
    from micropython import const  # noqa: F401
except ImportError:  # CPython

    def const(x):
        return x


try:
    from time import ticks_add, ticks_diff  # noqa: F401
except ImportError:  # CPython: emulate the ESP32's 2**30 ms wrap so host code sees the same behaviour
    _TICKS_PERIOD = 1 << 30
    _TICKS_HALF = _TICKS_PERIOD >> 1

    def ticks_add(t, delta):
        return (t + delta) % _TICKS_PERIOD

    def ticks_diff(a, b):
        return ((a - b + _TICKS_HALF) % _TICKS_PERIOD) - _TICKS_HALF


def wrap180(a_deg):
    """Angle to [-180, 180)."""
    a_deg = a_deg % 360.0
    if a_deg >= 180.0:
        a_deg -= 360.0
    return a_deg


def wrap360(a_deg):
    """Angle to [0, 360)."""
    a_deg = a_deg % 360.0
    if a_deg >= 360.0:  # -1e-9 % 360 can round to 360.0
        a_deg = 0.0
    return a_deg
