"""Environment presets and the fault list.

A preset is a partial parameter set merged over boat_params.json (see params.merge). Add a preset by
adding an entry to PRESETS. A fault is given as NAME@T or NAME@T:D (start T seconds into the run,
lasting D seconds; faults without a duration are instantaneous or last until something clears
them). FAULTS documents every name; runner.SimRun applies them.
"""

PRESETS = {
    "calm": {"water": {"current_mps": 0.0, "wave_yaw_rms_deg": 1.0}, "wind": {"speed_mps": 0.0}},
    "current": {"water": {"current_mps": 0.2, "current_dir_deg": 120.0, "wave_yaw_rms_deg": 1.5},
                "wind": {"speed_mps": 0.0}},
    "wind": {"water": {"current_mps": 0.0, "wave_yaw_rms_deg": 2.0},
             "wind": {"speed_mps": 5.0, "dir_deg": 240.0, "gust_sd_frac": 0.2}},
    "gusts": {"water": {"current_mps": 0.05, "wave_yaw_rms_deg": 2.0},
              "wind": {"speed_mps": 7.0, "dir_deg": 240.0, "gust_sd_frac": 0.4, "gust_tau_s": 4.0}},
    "rough": {"water": {"current_mps": 0.25, "current_dir_deg": 60.0, "wave_yaw_rms_deg": 3.0},
              "wind": {"speed_mps": 8.0, "dir_deg": 200.0, "gust_sd_frac": 0.35}},
}

# name: (needs a duration, description)
FAULTS = {
    "rtk_float": (True, "GNSS position RTK float (0.2-0.5 m noise with jumps)"),
    "rtk_single": (True, "GNSS single fix (1-2 m), no dual-antenna heading"),
    "heading_loss": (True, "dual-antenna heading invalid (relPosHeadingValid = 0)"),
    "gnss_dropout": (True, "no GNSS output at all (bridge); then single, float, fixed"),
    "compass_bend": (True, "the pilot's compass bent 6 deg by a steel bridge"),
    "pilot_hang_steer": (False, "ST2000+ keeps talking and taking keys, the rudder stops tracking"),
    "pilot_hang_keys": (False, "ST2000+ ignores course keystrokes (Standby/Auto still work)"),
    "pilot_key_standby": (False, "a person presses Standby on the ST2000+"),
    "pilot_key_standby_on_auto": (False, "from T on, a person presses Standby on the ST2000+ just as the "
                                         "firmware's next Auto keystroke arrives (the pilot acts on the "
                                         "person's key first: the takeover race)"),
    "pilot_key_auto": (False, "a person presses Auto on the ST2000+"),
    "pilot_key_minus10": (False, "a person presses -10 on the ST2000+"),
    "pilot_key_plus10": (False, "a person presses +10 on the ST2000+"),
    "pilot_key_minus1": (False, "a person presses -1 on the ST2000+"),
    "pilot_key_plus1": (False, "a person presses +1 on the ST2000+"),
    "pilot_silent": (True, "the ST2000+ sends no status (it still steers and takes keys)"),
    "st_noise": (True, "SeaTalk noise: 3 % of characters corrupted, 1 % dropped"),
    "st_tx_lost": (True, "lost echo: the firmware's SeaTalk bytes never reach the bus"),
    "st_rx_lost": (True, "the firmware's SeaTalk receiver hears nothing"),
    "st_other_talker": (True, "another instrument sends wind datagrams without waiting for idle (collisions)"),
    "motor_link_loss": (True, "the motor controller stops replying and ignores setpoints"),
    "estop": (True, "E-stop input active"),
    "remote_key_echo": (False, "a hand remote with the firmware's sender id repeats the firmware's next "
                               "keystroke 0.1 s after it (a person's key that looks like our own echo)"),
    "button_ack": (False, "a person presses ACK on the HMI"),
    "reset": (False, "the firmware restarts (process restarted with the same data dir)"),
    "button_standby": (False, "STANDBY pressed on the HMI"),
    "button_engage": (False, "ENGAGE pressed on the HMI"),
    "button_trial": (False, "TRIAL (commissioning trial) asked on the HMI"),
}


# A bridge on a canal (issue 12): RTK float on the approach, no GNSS under it, then the receiver
# reacquires (single, then float, set by the gnss reacquire_* parameters), the compass bent by
# the steel. bridge_faults(t_s, dropout_s) gives the fault list, BRIDGE_GNSS the parameters.
BRIDGE_GNSS = {"gnss": {"reacquire_single_s": 5.0, "reacquire_float_s": 9.0}}


def bridge_faults(t_s, dropout_s, float_before_s=6.0, bend_s=None):
    bend_s = bend_s if bend_s is not None else dropout_s + 6.0
    return ["rtk_float@%g:%g" % (t_s, float_before_s),
            "gnss_dropout@%g:%g" % (t_s + float_before_s, dropout_s),
            "compass_bend@%g:%g" % (t_s + float_before_s - 3.0, bend_s)]


def parse_fault(text):
    """'name@t[:d]' -> (name, t_s, d_s or None); ValueError with a one-line reason."""
    name, sep, when = text.partition("@")
    if name not in FAULTS:
        raise ValueError("fault %r: unknown name %r; names: %s" % (text, name, ", ".join(sorted(FAULTS))))
    if not sep:
        raise ValueError("fault %r: give its start time, %s@T%s (T, D in seconds)"
                         % (text, name, ":D" if FAULTS[name][0] else ""))
    t, _, d = when.partition(":")
    try:
        t_s = float(t)
        d_s = float(d) if d else None
    except ValueError:
        raise ValueError("fault %r: T and D must be numbers of seconds (%s@T:D)" % (text, name)) from None
    if t_s < 0 or (d_s is not None and d_s <= 0):
        raise ValueError("fault %r: T must be >= 0 and D > 0 seconds" % text)
    if FAULTS[name][0] and d_s is None:
        raise ValueError("fault %r needs a duration: %s@T:D" % (text, name))
    return name, t_s, d_s
