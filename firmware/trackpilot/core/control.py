"""The navigation and guidance half of one control step, shared by the app and by replay.

`guide_epoch` moves the antenna position to the boat's reference point (lever arm), updates the
track progress and, when the app is steering, runs the guidance law. The app (app.py) and the
replay tool (tools/replay.py) both call exactly this, so a replay of a log reproduces the app's
commands.

Usage:
    ref, out = guide_epoch(fix, progress, law, cfg["boat"], guiding=True)
"""
from trackpilot.nav.fix import RTK_NAMES
from trackpilot.nav.geo import apply_lever_arm_hp

EPOCH_S = 0.2  # the nominal period (5 Hz, ubxcfg's CFG-RATE-MEAS); the app passes the measured one

# the measured epoch interval is trusted within these bounds (25 Hz .. 1 Hz)
DT_MIN_S = 0.04
DT_MAX_S = 1.0


def epoch_dt_s(interval_ms):
    """The control step's period from the parser's measured epoch interval (0: not known yet,
    then the configured 5 Hz), clamped to the rates the receiver can be set to."""
    if interval_ms <= 0:
        return EPOCH_S
    dt = interval_ms * 0.001
    return DT_MIN_S if dt < DT_MIN_S else DT_MAX_S if dt > DT_MAX_S else dt


def gnss_ok(fix, steer_min_rtk):
    """(ok, reason): is this epoch good enough to steer by?"""
    if not fix.pos_valid:
        return False, "no GNSS position"
    if fix.rtk < steer_min_rtk:
        return False, "RTK %s" % RTK_NAMES[fix.rtk]
    if not fix.heading_valid:
        return False, "heading invalid"
    return True, ""


def guide_epoch(fix, progress, law, boat_cfg, guiding, dt_s=EPOCH_S):
    """Returns (ref, out): ref = (lat_e7, lon_e7, lat_hp, lon_hp) of the reference point or None
    when the epoch has no position or heading; out = the law's GuidanceOut when `guiding`, else
    None. `progress` is updated whenever there is a position and a heading."""
    if progress is None or not fix.pos_valid or not fix.heading_valid:
        return None, None
    ref = apply_lever_arm_hp(fix.lat_e7, fix.lon_e7, fix.lat_hp, fix.lon_hp, fix.heading_deg,
                             boat_cfg["antenna_fwd_m"], boat_cfg["antenna_stbd_m"])
    progress.update(ref[0], ref[1], ref[2], ref[3])
    out = law.step(fix, progress, dt_s) if guiding else None
    return ref, out
