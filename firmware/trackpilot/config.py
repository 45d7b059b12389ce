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


# Every setting with its default and its allowed range or choices, one line each:
#   key kind default [lo hi | choice|choice...]    under a [section] line
# kind: f float, i int (lo hi: the allowed range), b bool (true/false), s string (optionally the
# allowed choices, separated by |; '' is the empty string). One text constant, so on the ESP32 the
# table stays in flash: the dicts that validation needs are built by schema() when asked for and
# dropped afterwards (docs/MEMORY.md), not kept on the heap for the life of the app.
_TABLE = """
[boat]
name s trackpilot
min_turn_radius_m f 9.0 2.0 100.0
antenna_fwd_m f 0.0 -10.0 10.0               # lever arm of the position antenna from the
antenna_stbd_m f 0.0 -5.0 5.0                # reference point (forward, starboard)
heading_offset_deg f 0.0 -180.0 180.0        # dual-antenna baseline mounting offset
[guidance]
law s los seed|los
# plus "<law>_<parameter>" for every parameter of every law, from guidance.py's PARAMS
# tables (seed_k_y_deg_per_m, los_lookahead_gain, ...): see _rows below
[modes]
# GNSS gap inside AUTO: dead reckoning this long, then ALARM (docs/MODES.md "GNSS gaps")
gnss_hold_s f 40.0 0.0 120.0
gnss_stale_ms i 1000 300 10000
xte_alarm_m f 5.0 0.5 100.0
on_arrival s standby standby|hold
engage_min_rtk s fixed fixed|float|single
steer_min_rtk s float fixed|float|single
correction_max_age_s f 0.0 0.0 600.0         # 0 = not checked (no NTRIP configured)
motor_release_on_standby b true
[pilot]
sender_id i 1 1 15                           # 0 is the pilot's own keypad: never ours
key_interval_ms i 250 50 5000
odd_rule s dotnet dotnet|knauf
status_timeout_ms i 3500 1000 30000
deadband_deg i 1 0 10
compass_offset_tc_s f 20.0 0.0 600.0         # 0: steer by the instantaneous difference
compass_offset_max_rate_dps f 2.0 0.1 90.0   # no offset samples in faster turns
# hang check (c): error above converge_err_deg for a whole window in which the heading
# turned towards the locked course by less than converge_progress_deg (st2000.py)
converge_err_deg f 15.0 5.0 90.0
converge_window_ms i 15000 5000 120000
converge_progress_deg f 8.0 1.0 90.0
converge_min_speed_mps f 0.8 0.0 5.0         # slower: the rudder barely bites
# SeaTalk bus timing (stlink.py). The echo of each byte must arrive within
# echo_timeout_ms of its write: the UART RX timeout (ESP-IDF default ~23 ms at 4800 Bd,
# lowered by wiring_esp32) plus event-loop latency; confirm on the boat (docs/SEATALK.md)
echo_timeout_ms i 40 5 200
idle_ms i 3 3 50                             # bus idle before talking (>= 10 bit times = 2.1 ms)
backoff_min_ms i 2 1 500
backoff_max_ms i 50 2 1000
retries i 5 0 20                             # per datagram after a collision or lost echo
# reaction to datagrams that fail after all retries (app.py, modes.seatalk_lost)
link_alarm_fails i 2 1 20                    # in a row: SeaTalk alarm
link_lost_fails i 3 1 50                     # in a row: cannot steer, AUTO -> ALARM
link_lost_ms i 5000 500 60000                # ... or this long without a datagram sent
[motor]
link s rs232 rs232|pwm|none
frame s ascii ascii|binary
keepalive_ms i 200 50 5000
reply_timeout_ms i 1500 200 20000
expect_replies b true
rpm_per_mps f 400.0 1.0 5000.0               # speed -> RPM map (linear part)
rpm_offset f 0.0 -500.0 500.0
rpm_max i 1500 0 10000
slow_rpm i 200 0 5000
release_rpm i 0 0 5000
sog_loop b false                             # outer loop on GPS speed over ground
sog_loop_gain_rpm_per_mps f 150.0 0.0 2000.0
sog_loop_limit_rpm i 300 0 3000
low_battery_v f 44.0 0.0 100.0
[log]
dir s /log
flush_ms i 1000 100 10000
# retention budget (docs/LOG_FORMAT.md): parts of max_file_bytes; older sessions are
# deleted, oldest first, only when less than min_free_bytes (at most 1/8 of the
# filesystem) is free
max_file_bytes i 262144 4096 16777216
min_free_bytes i 262144 0 16777216
[ntrip]
enabled b false
host s ''
port i 2101 1 65535
mountpoint s ''
user s ''
password s ''
gga_interval_s i 10 0 600
[wifi]  # trackpilot/wifi.py, docs/WIRING.md; the passwords are never logged
enabled b false                              # station: join the boat's router
ssid s ''
password s ''
ap_enabled b false                           # access point for a laptop (WPA2 only)
ap_ssid s trackpilot
ap_password s ''                             # 8..63 characters, else no access point
connect_timeout_ms i 15000 2000 120000
backoff_min_ms i 2000 500 60000
backoff_max_ms i 60000 1000 600000
[wiring]  # ESP32-S3 reference hardware, docs/WIRING.md; -1 = not fitted
gnss_uart i 1 0 2
gnss_tx i 17 -1 48
gnss_rx i 18 -1 48
gnss_baud i 115200 9600 921600
seatalk_uart i 2 0 2
seatalk_tx i 4 -1 48
seatalk_rx i 5 -1 48
seatalk_invert b true
motor_uart i 0 0 2
motor_tx i 43 -1 48
motor_rx i 44 -1 48
motor_baud i 9600 1200 115200
throttle_pwm i -1 -1 48
wind_source s none none|seatalk
i2c_sda i 8 -1 48
i2c_scl i 9 -1 48
display_addr i 60 0 127
btn_engage i 10 -1 48
btn_standby i 11 -1 48
btn_next i 12 -1 48
btn_prev i 13 -1 48
btn_page i 14 -1 48
btn_ack i 21 -1 48
estop_in i 1 -1 48
estop_active_low b true
led_gps i 38 -1 48
led_auto i 39 -1 48
led_alarm i 40 -1 48
buzzer i 41 -1 48
skip_app_pin i 0 -1 48                       # not read any more: main.py's fixed pin (docs/WIRING.md)
watchdog_ms i 8000 1000 60000
[hmi]
boat_id i 1 0 65535
render_ms i 200 50 5000
key_file s /hmi.key
counter_file s /auth_rx.bin
command_port i 10112 1 65535
remote_enabled b false
[telemetry]
enabled b false
udp_host s 255.255.255.255
udp_port i 10110 1 65535
status_port i 10111 1 65535
period_ms i 1000 100 10000
console b false                              # also print `TPS <hex>` status lines on the USB console
"""


def _value(kind, tok):
    if kind == "f":
        return float(tok)
    if kind == "i":
        return int(tok)
    if kind == "b":
        return tok == "true"
    return "" if tok == "''" else tok


def _law_rows():
    from trackpilot.guidance import LAWS

    for law_name, cls in LAWS.items():
        for key, spec in cls.PARAMS.items():
            if law_name == "los" and key == "turn_radius_m":
                continue  # from boat.min_turn_radius_m
            yield "%s_%s" % (law_name, key), (float(spec[0]), "f", spec[2], spec[3])


def _rows():
    """(section, key, (default, kind, lo, hi)) for every setting, in the table's order; the
    guidance section ends with "<law>_<parameter>" for every parameter of every law (guidance.py's
    PARAMS tables: seed_k_y_deg_per_m, los_lookahead_gain, ...)."""
    sec = None
    i = 0
    n = len(_TABLE)
    while i < n:
        j = _TABLE.find("\n", i)
        if j < 0:
            j = n
        line = _TABLE[i:j]
        i = j + 1
        c = line.find("#")
        if c >= 0:
            line = line[:c]
        tok = line.split()
        if not tok:
            continue
        if tok[0][0] == "[":
            if sec == "guidance":
                for key, spec in _law_rows():
                    yield sec, key, spec
            sec = tok[0][1:-1]
            continue
        kind = tok[1]
        default = _value(kind, tok[2])
        if kind in ("f", "i"):
            spec = (default, kind, _value(kind, tok[3]), _value(kind, tok[4]))
        elif kind == "s" and len(tok) > 3:
            spec = (default, kind, tuple(tok[3].split("|")), None)
        else:
            spec = (default, kind, None, None)
        yield sec, tok[0], spec


def schema():
    """{section: {key: (default, kind, lo, hi)}}, built from the table on each call (for
    validation; the caller drops it)."""
    out = {}
    for sec, key, spec in _rows():
        body = out.get(sec)
        if body is None:
            body = out[sec] = {}
        body[key] = spec
    return out


def defaults():
    out = {}
    for sec, key, spec in _rows():
        body = out.get(sec)
        if body is None:
            body = out[sec] = {}
        body[key] = spec[0]
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


def _check(sec, key, value, spec, errors):
    default, kind, lo, hi = spec
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
    table = schema()
    for sec, body in cfg.items():
        if sec not in table:
            errors.append("unknown section %r" % sec)
            continue
        if not isinstance(body, dict):
            errors.append("%s: must be an object" % sec)
            continue
        for key, value in body.items():
            spec = table[sec].get(key)
            if spec is None:
                errors.append("%s.%s: unknown setting" % (sec, key))
            else:
                _check(sec, key, value, spec, errors)
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
