# Small portability layer so firmware modules also import under CPython (host tools, tests).
try:
    from micropython import const  # noqa: F401
except ImportError:  # CPython

    def const(x):
        return x


# Millisecond ticks wrap at 2**30 as on the ESP32, on every platform (the unix port wraps at 2**62,
# which would hide wrap bugs). The core only ever compares t_ms values through these two.
TICKS_PERIOD = const(1 << 30)
TICKS_MASK = const((1 << 30) - 1)
_TICKS_HALF = const(1 << 29)


def ticks_add(t_ms, delta_ms):
    return (t_ms + delta_ms) & TICKS_MASK


def ticks_diff(a_ms, b_ms):
    """a - b in ms, correct across the wrap while |a - b| < 2**29 ms (6.2 days)."""
    return ((a_ms - b_ms + _TICKS_HALF) & TICKS_MASK) - _TICKS_HALF


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
