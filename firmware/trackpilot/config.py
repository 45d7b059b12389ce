"""Configuration: a JSON file on flash, validated against a schema, written atomically.

A file that does not parse or validate never replaces the active configuration: `load()` falls back
to the last good copy (`config.good.json`, written whenever a file validates) and reports why, or to
the defaults with the reason, never silently. Anything wrong with the file (unreadable, not UTF-8,
not JSON, out of memory) is a rejection like any other; load() never raises. `rejected(problems)`
tells the app that a file was rejected: it raises the config alarm and refuses ENGAGE until a
person acknowledges (docs/MODES.md).

Secret settings (a key named password/secret/token/key, or ending in _password/_secret/_token/_key:
`is_secret`) never have their value in an error message: errors go to the log, logs go to laptops.

Usage:
    cfg, problems = load("/config.json")     # problems: list of strings to log; cfg always valid
    cfg["guidance"]["law"]                    # "seed" or "los"
    errors = validate(candidate)              # [] when good
    save("/config.json", candidate)           # raises ConfigError, keeps the old file on error
"""
import json

try:
    import os
except ImportError:  # pragma: no cover
    import uos as os


class ConfigError(Exception):
    pass


# Every setting with its default and its allowed range or choices, as (key, default, kind, lo, hi)
# rows under their section: kind "f" float, "i" int, "b" bool, "s" string (lo = tuple of choices or
# None). One constant of tuples, not dicts: frozen into the ESP32 image it stays in flash, and
# nothing of it is built on the heap (validation scans it; docs/MEMORY.md).
SCHEMA = (
    ("boat", (
        ("name", "trackpilot", "s", None, None),
        ("min_turn_radius_m", 9.0, "f", 2.0, 100.0),
        ("antenna_fwd_m", 0.0, "f", -10.0, 10.0),  # lever arm of the position antenna from the
        ("antenna_stbd_m", 0.0, "f", -5.0, 5.0),  # reference point (forward, starboard)
        ("heading_offset_deg", 0.0, "f", -180.0, 180.0),  # dual-antenna baseline mounting offset
    )),
    ("guidance", (
        ("law", "los", "s", ("seed", "los"), None),
        # plus "<law>_<parameter>" for every parameter of every law, from guidance.py's PARAMS
        # tables (seed_k_y_deg_per_m, los_lookahead_gain, ...): see _law_rows below
    )),
    ("modes", (
        # GNSS gap inside AUTO: dead reckoning this long, then ALARM (docs/MODES.md "GNSS gaps")
        ("gnss_hold_s", 40.0, "f", 0.0, 120.0),
        ("gnss_stale_ms", 1000, "i", 300, 10000),
        ("xte_alarm_m", 5.0, "f", 0.5, 100.0),
        ("on_arrival", "standby", "s", ("standby", "hold"), None),
        ("engage_min_rtk", "fixed", "s", ("fixed", "float", "single"), None),
        ("steer_min_rtk", "float", "s", ("fixed", "float", "single"), None),
        ("correction_max_age_s", 0.0, "f", 0.0, 600.0),  # 0 = not checked (no NTRIP configured)
        ("motor_release_on_standby", True, "b", None, None),
    )),
    ("pilot", (
        ("sender_id", 1, "i", 1, 15),  # 0 is the pilot's own keypad: never ours
        ("key_interval_ms", 250, "i", 50, 5000),
        ("odd_rule", "dotnet", "s", ("dotnet", "knauf"), None),
        ("status_timeout_ms", 3500, "i", 1000, 30000),
        # the rudder report (0x84 / 0x9C): 1 as PROTOCOLS.md (+ = steer right), -1 reversed, 0 not
        # used; to be confirmed on the boat (tune finds it from the trial, docs/COMMISSIONING.md)
        ("rudder_sign", 1, "i", -1, 1),
        ("deadband_deg", 1, "i", 0, 10),  # the pilot's deadband: the estimate's prior (core/pilotdb.py)
        # share of the estimate the locked course is put beyond the wanted heading on a los
        # straight in AUTO (docs/NAVIGATION.md "The pilot's deadband"); 0: off
        ("deadband_comp_frac", 0.8, "f", 0.0, 1.5),
        ("compass_offset_tc_s", 20.0, "f", 0.0, 600.0),  # 0: steer by the instantaneous difference
        ("compass_offset_max_rate_dps", 2.0, "f", 0.1, 90.0),  # no offset samples in faster turns
        # hang check (c): error above converge_err_deg for a whole window in which the heading
        # turned towards the locked course by less than converge_progress_deg (st2000.py)
        ("converge_err_deg", 15.0, "f", 5.0, 90.0),
        ("converge_window_ms", 15000, "i", 5000, 120000),
        ("converge_progress_deg", 8.0, "f", 1.0, 90.0),
        ("converge_min_speed_mps", 0.8, "f", 0.0, 5.0),  # slower: the rudder barely bites
        # SeaTalk bus timing (stlink.py). The echo of each byte must arrive within
        # echo_timeout_ms of its write: the UART RX timeout (ESP-IDF default ~23 ms at 4800 Bd,
        # lowered by wiring_esp32) plus event-loop latency; confirm on the boat (docs/SEATALK.md)
        ("echo_timeout_ms", 40, "i", 5, 200),
        ("idle_ms", 3, "i", 3, 50),  # bus idle before talking (>= 10 bit times = 2.1 ms)
        ("backoff_min_ms", 2, "i", 1, 500),
        ("backoff_max_ms", 50, "i", 2, 1000),
        ("retries", 5, "i", 0, 20),  # per datagram after a collision or lost echo
        # reaction to datagrams that fail after all retries (app.py, modes.seatalk_lost)
        ("link_alarm_fails", 2, "i", 1, 20),  # in a row: SeaTalk alarm
        ("link_lost_fails", 3, "i", 1, 50),  # in a row: cannot steer, AUTO -> ALARM
        ("link_lost_ms", 5000, "i", 500, 60000),  # ... or this long without a datagram sent
    )),
    ("motor", (
        ("link", "rs232", "s", ("rs232", "pwm", "none"), None),
        ("frame", "ascii", "s", ("ascii", "binary"), None),
        ("keepalive_ms", 200, "i", 50, 5000),
        ("reply_timeout_ms", 1500, "i", 200, 20000),
        ("expect_replies", True, "b", None, None),
        ("rpm_per_mps", 400.0, "f", 1.0, 5000.0),  # speed -> RPM map (linear part)
        ("rpm_offset", 0.0, "f", -500.0, 500.0),
        ("rpm_max", 1500, "i", 0, 10000),
        ("slow_rpm", 200, "i", 0, 5000),
        ("release_rpm", 0, "i", 0, 5000),
        ("sog_loop", False, "b", None, None),  # outer loop on GPS speed over ground
        ("sog_loop_gain_rpm_per_mps", 150.0, "f", 0.0, 2000.0),
        ("sog_loop_limit_rpm", 300, "i", 0, 3000),
        ("low_battery_v", 44.0, "f", 0.0, 100.0),
    )),
    ("log", (
        ("dir", "/log", "s", None, None),
        ("flush_ms", 1000, "i", 100, 10000),
        # retention budget (docs/LOG_FORMAT.md): parts of max_file_bytes; older sessions are
        # deleted, oldest first, only when less than min_free_bytes (at most 1/8 of the
        # filesystem) is free
        ("max_file_bytes", 262144, "i", 4096, 16777216),
        ("min_free_bytes", 262144, "i", 0, 16777216),
    )),
    ("ntrip", (
        ("enabled", False, "b", None, None),
        ("host", "", "s", None, None),
        ("port", 2101, "i", 1, 65535),
        ("mountpoint", "", "s", None, None),
        ("user", "", "s", None, None),
        ("password", "", "s", None, None),
        ("gga_interval_s", 10, "i", 0, 600),
    )),
    ("wifi", (  # trackpilot/board/wifi.py, docs/WIRING.md; the passwords are never logged
        ("enabled", False, "b", None, None),  # station: join the boat's router
        ("ssid", "", "s", None, None),
        ("password", "", "s", None, None),
        ("ap_enabled", False, "b", None, None),  # access point for a laptop (WPA2 only)
        ("ap_ssid", "trackpilot", "s", None, None),
        ("ap_password", "", "s", None, None),  # 8..63 characters, else no access point
        ("connect_timeout_ms", 15000, "i", 2000, 120000),
        ("backoff_min_ms", 2000, "i", 500, 60000),
        ("backoff_max_ms", 60000, "i", 1000, 600000),
    )),
    ("wiring", (  # ESP32-S3 reference hardware, docs/WIRING.md; -1 = not fitted
        ("gnss_uart", 1, "i", 0, 2),
        ("gnss_tx", 17, "i", -1, 48),
        ("gnss_rx", 18, "i", -1, 48),
        ("gnss_baud", 115200, "i", 9600, 921600),
        ("seatalk_uart", 2, "i", 0, 2),
        ("seatalk_tx", 4, "i", -1, 48),
        ("seatalk_rx", 5, "i", -1, 48),
        ("seatalk_invert", True, "b", None, None),
        ("motor_uart", 0, "i", 0, 2),
        ("motor_tx", 43, "i", -1, 48),
        ("motor_rx", 44, "i", -1, 48),
        ("motor_baud", 9600, "i", 1200, 115200),
        ("throttle_pwm", -1, "i", -1, 48),
        ("wind_source", "none", "s", ("none", "seatalk"), None),
        ("i2c_sda", 8, "i", -1, 48),
        ("i2c_scl", 9, "i", -1, 48),
        ("display_addr", 60, "i", 0, 127),
        ("btn_engage", 10, "i", -1, 48),
        ("btn_standby", 11, "i", -1, 48),
        ("btn_next", 12, "i", -1, 48),
        ("btn_prev", 13, "i", -1, 48),
        ("btn_page", 14, "i", -1, 48),
        ("btn_ack", 21, "i", -1, 48),
        ("estop_in", 1, "i", -1, 48),
        ("estop_active_low", True, "b", None, None),
        ("led_gps", 38, "i", -1, 48),
        ("led_auto", 39, "i", -1, 48),
        ("led_alarm", 40, "i", -1, 48),
        ("buzzer", 41, "i", -1, 48),
        ("skip_app_pin", 0, "i", -1, 48),  # not read any more: main.py's fixed pin (docs/WIRING.md)
        ("watchdog_ms", 8000, "i", 1000, 60000),
    )),
    ("hmi", (
        ("boat_id", 1, "i", 0, 65535),
        ("render_ms", 200, "i", 50, 5000),
        ("key_file", "/hmi.key", "s", None, None),
        ("counter_file", "/auth_rx.bin", "s", None, None),
        ("command_port", 10112, "i", 1, 65535),
        ("remote_enabled", False, "b", None, None),
    )),
    ("trial", (  # commissioning trial (trial.py, docs/COMMISSIONING.md)
        ("rpm_low", 600, "i", 100, 3000),
        ("rpm_high", 1000, "i", 100, 3000),
        ("straight_s", 45, "i", 10, 300),
        ("straight_high_s", 0, "i", 0, 300),  # a straight at rpm_high after the turn back (COMMISSIONING.md)
        ("step_max_s", 25, "i", 8, 120),
        ("zigzag_deg", 10, "i", 5, 30),
        ("circle_lead_deg", 150, "i", 40, 170),
        ("circle_turns", 2, "i", 1, 5),
        ("circle_max_s", 90, "i", 30, 300),
        ("circle_low_turns", 0, "i", 0, 3),  # 1: a circle after the low-speed zig-zag (COMMISSIONING.md)
        ("max_distance_m", 600.0, "f", 50.0, 5000.0),
        ("max_duration_s", 600, "i", 60, 3600),
        ("end_margin_s", 10, "i", 0, 120),  # the script ends this long before max_duration_s
        ("min_speed_mps", 0.5, "f", 0.1, 3.0),
    )),
    ("telemetry", (
        ("enabled", False, "b", None, None),
        ("udp_host", "255.255.255.255", "s", None, None),
        ("udp_port", 10110, "i", 1, 65535),
        ("status_port", 10111, "i", 1, 65535),
        ("period_ms", 1000, "i", 100, 10000),
        ("console", False, "b", None, None),  # also print `TPS <hex>` status lines on the USB console
    )),
)


def _law_rows():
    """The guidance section's "<law>_<parameter>" rows, from guidance.py's PARAMS tables."""
    from trackpilot.nav.guidance import LAWS

    for law_name, cls in LAWS.items():
        for key, spec in cls.PARAMS.items():
            if law_name == "los" and key == "turn_radius_m":
                continue  # from boat.min_turn_radius_m
            yield ("%s_%s" % (law_name, key), float(spec[0]), "f", spec[2], spec[3])


def _section_rows(sec):
    """The rows of a section (a list, with the law parameters for "guidance"), None if unknown."""
    for name, rows in SCHEMA:
        if name == sec:
            return list(rows) + list(_law_rows()) if sec == "guidance" else rows
    return None


def _row(rows, key):
    for row in rows:
        if row[0] == key:
            return row
    return None


def defaults():
    out = {}
    for sec, rows in SCHEMA:
        body = out[sec] = {}
        for row in rows:
            body[row[0]] = row[1]
        if sec == "guidance":
            for row in _law_rows():
                body[row[0]] = row[1]
    return out


_SECRET_WORDS = ("password", "secret", "token", "key")


def is_secret(key):
    """A setting whose value must never appear in a message (password, wifi_password, api_key...)."""
    k = key.lower()
    for w in _SECRET_WORDS:
        if k == w or k.endswith("_" + w) or (w != "key" and w in k):
            return True
    return False


def _shown(key, value):
    return "(value not shown: secret)" if is_secret(key) else repr(value)


def _check(sec, key, value, row, errors):
    kind = row[2]
    lo = row[3]
    hi = row[4]
    where = "%s.%s" % (sec, key)
    got = _shown(key, value)
    if kind == "b":
        if value is not True and value is not False:
            errors.append("%s: must be true or false, got %s" % (where, got))
        return
    if kind == "s":
        if not isinstance(value, str):
            errors.append("%s: must be a string, got %s" % (where, got))
        elif lo is not None and value not in lo:
            errors.append("%s: must be one of %s, got %s" % (where, "/".join(lo), got))
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        errors.append("%s: must be a number, got %s" % (where, got))
        return
    if kind == "f" and isinstance(value, int):
        value = float(value)
    if kind == "i" and not isinstance(value, int):
        errors.append("%s: must be a whole number, got %s" % (where, got))
        return
    if value != value or value < lo or value > hi:  # value != value: NaN
        errors.append("%s: %s out of range [%s, %s]" % (where, got, lo, hi))


def validate(cfg):
    """Errors (strings) for a candidate configuration; [] when it is good. Unknown keys are errors
    (a typo must not silently fall back to a default)."""
    errors = []
    if not isinstance(cfg, dict):
        return ["configuration must be a JSON object"]
    for sec, body in cfg.items():
        rows = _section_rows(sec)
        if rows is None:
            errors.append("unknown section %r" % sec)
            continue
        if not isinstance(body, dict):
            errors.append("%s: must be an object" % sec)
            continue
        for key, value in body.items():
            row = _row(rows, key)
            if row is None:
                errors.append("%s.%s: unknown setting" % (sec, key))
            else:
                _check(sec, key, value, row, errors)
    return errors


def merged(cfg):
    """Defaults overlaid with a validated (possibly partial) configuration."""
    out = defaults()
    for sec, body in cfg.items():
        out[sec].update(body)
    return out


def parse(text):
    """Text -> (complete config, errors). On errors the config is None."""
    try:
        cfg = json.loads(text)
    except ValueError as e:  # UnicodeError is a ValueError too
        return None, ["not valid JSON: %s" % e]
    errors = validate(cfg)
    if errors:
        return None, errors
    return merged(cfg), []


def _read(path):
    with open(path, "rb") as f:
        raw = f.read()
    try:
        return raw.decode("utf-8")
    except UnicodeError:
        raise ValueError("not UTF-8 text (a character saved in another encoding?)")


def _exists(path):
    try:
        os.stat(path)
        return True
    except OSError:
        return False


def _good_path(path):
    return path[:-5] + ".good.json" if path.endswith(".json") else path + ".good"


def write_atomic(path, text):
    """Write to a temporary name, then rename (atomic on littlefs and POSIX)."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    try:
        os.rename(tmp, path)
    except OSError:
        try:  # some filesystems refuse to rename over an existing file
            os.remove(path)
        except OSError:
            pass
        os.rename(tmp, path)


REJECTED = " rejected: "  # in the problem naming a file that was rejected


def rejected(problems):
    """True when load() rejected a configuration file (the app raises the config alarm)."""
    for p in problems:
        if REJECTED in p:
            return True
    return False


def _load_file(path):
    try:
        return parse(_read(path))
    except Exception as e:  # OSError, not UTF-8, MemoryError: a bad file, never a boot loop
        return None, ["cannot read: %s" % (e,)]


def load(path):
    """Returns (config, problems). The config is always complete and valid; never raises."""
    problems = []
    if _exists(path):
        cfg, errors = _load_file(path)
        if cfg is not None:
            good = _good_path(path)
            try:
                text = json.dumps(cfg)
                if not _exists(good) or _read(good) != text:
                    write_atomic(good, text)
            except OSError as e:
                problems.append("could not keep a last-good copy: %s" % e)
            return cfg, problems
        problems.append("%s%s%s" % (path, REJECTED, "; ".join(errors)))
        good = _good_path(path)
        if _exists(good):
            cfg, errors = _load_file(good)
            if cfg is not None:
                problems.append("using the last good configuration %s" % good)
                return cfg, problems
            problems.append("%s rejected too: %s" % (good, "; ".join(errors)))
        problems.append("using the built-in defaults")
        return defaults(), problems
    problems.append("%s not found: using the built-in defaults" % path)
    return defaults(), problems


def save(path, cfg):
    """Validate and write atomically; raises ConfigError and leaves the old file on a bad config."""
    errors = validate(cfg)
    if errors:
        raise ConfigError("; ".join(errors))
    text = json.dumps(merged(cfg))
    write_atomic(path, text)
    write_atomic(_good_path(path), text)
