"""Representative HmiStatus states for previews and the reference images (tests/data/hmi/).

Usage:
    from tphmi.preview.samples import SAMPLES, sample
    st = sample("auto_right")
"""
from tphmi.status import HmiStatus

_BASE = {
    "boat_id": 7, "seq": 1234, "mode": 1, "rtk": 3, "pos_valid": True,
    "lat_e7": 514987654, "lon_e7": 36123456, "num_sv": 23, "h_acc_m": 0.014,
    "heading_valid": True, "heading_deg": 123.4, "heading_acc_deg": 0.3, "corr_age_s": 1.2,
    "sog_mps": 1.25, "nav_valid": True, "xte_m": 1.24, "leg": 2, "legs": 11, "to_wp_m": 187.4,
    "cmd_valid": True, "heading_cmd_deg": 125.6, "rpm_cmd": 1200, "rpm": 1185,
    "pilot_ok": True, "pilot_mode": 1, "compass_deg": 131.0, "locked_deg": 133.0,
    "keystrokes": 412, "hang_recoveries": 1, "cmd_counter": 17,
}

# name -> changes from _BASE
_CHANGES = (
    ("auto_right", {}),
    ("auto_left_far", {"xte_m": -14.7, "alarms": 64, "sounding": 64,
                       "alarm_reason": "cross-track error -14.7 m beyond 5.0 m"}),
    ("standby_refused", {"mode": 0, "rtk": 2, "xte_m": -0.4, "rpm_cmd": 0, "rpm": 0, "pilot_mode": 0,
                         "refusal": "no RTK fixed solution (float)"}),
    ("alarm_gnss", {"mode": 2, "rtk": 1, "xte_m": 3.1, "alarms": 6, "sounding": 4, "corr_age_s": 42.0,
                    "alarm_reason": "RTK lost for more than 10 s (single)", "cmd_valid": False}),
    ("estop", {"mode": 3, "estop_input": True, "alarms": 256, "sounding": 256, "rpm_cmd": 0, "rpm": 0,
               "alarm_reason": "E-stop pressed"}),
    ("no_track", {"mode": 0, "nav_valid": False, "legs": 0, "pilot_ok": False, "pilot_mode": 5,
                  "heading_valid": False, "pos_valid": False, "rtk": 0, "cmd_valid": False}),
)
SAMPLES = tuple(n for n, _ in _CHANGES)


def sample(name):
    for n, ch in _CHANGES:
        if n == name:
            st = HmiStatus().update(_BASE)
            return st.update(ch)
    raise ValueError("no sample %r" % name)
