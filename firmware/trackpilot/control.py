"""The navigation and guidance half of one control step, shared by the app and by replay.

`guide_epoch` moves the antenna position to the boat's reference point (lever arm), updates the
track progress and, when the app is steering, runs the guidance law. The app (app.py) and the
replay tool (tools/replay.py) both call exactly this, so a replay of a log reproduces the app's
commands.

Usage:
    ref, out = guide_epoch(fix, progress, law, cfg["boat"], guiding=True)
"""
from trackpilot.fix import RTK_NAMES
from trackpilot.geo import apply_lever_arm_hp

EPOCH_S = 0.2  # the control step's nominal period (5 Hz GNSS epochs)


def gnss_ok(fix, steer_min_rtk):
    """(ok, reason): is this epoch good enough to steer by?"""
    if not fix.pos_valid:
        return False, "no GNSS position"
    if fix.rtk < steer_min_rtk:
        return False, "RTK %s" % RTK_NAMES[fix.rtk]
    if not fix.heading_valid:
        return False, "heading invalid"
    return True, ""


def guide_epoch(fix, progress, law, boat_cfg, guiding):
    """Returns (ref, out): ref = (lat_e7, lon_e7, lat_hp, lon_hp) of the reference point or None
    when the epoch has no position or heading; out = the law's GuidanceOut when `guiding`, else
    None. `progress` is updated whenever there is a position and a heading."""
    if progress is None or not fix.pos_valid or not fix.heading_valid:
        return None, None
    ref = apply_lever_arm_hp(fix.lat_e7, fix.lon_e7, fix.lat_hp, fix.lon_hp, fix.heading_deg,
                             boat_cfg["antenna_fwd_m"], boat_cfg["antenna_stbd_m"])
    progress.update(ref[0], ref[1], ref[2], ref[3])
    out = law.step(fix, progress, EPOCH_S) if guiding else None
    return ref, out
