# Configuration: validation, atomic save, and a bad file never replacing the last good one.
import os

from tpassert import eq, true, raises
from trackpilot import config as C

DIR = "/tmp/tp_cfg_test_%d" % (id(C) % 100000)


def _fresh():
    try:
        os.mkdir(DIR)
    except OSError:
        pass
    for name in os.listdir(DIR):
        os.remove(DIR + "/" + name)
    return DIR + "/config.json"


def _write(path, text):
    with open(path, "w") as f:
        f.write(text)


def test_defaults_validate():
    eq(C.validate(C.defaults()), [])


def test_errors_are_clear():
    errs = C.validate({"guidance": {"law": "pid"}, "motor": {"slow_rpm": -5, "bogus": 1}, "x": {}})
    text = "; ".join(errs)
    true("guidance.law" in text and "seed/los" in text, text)
    true("motor.slow_rpm" in text, text)
    true("motor.bogus: unknown" in text, text)
    true("unknown section 'x'" in text, text)


def test_missing_file_uses_defaults_and_says_so():
    path = _fresh()
    cfg, problems = C.load(path)
    eq(cfg["guidance"]["law"], "los")
    true("not found" in problems[0])


def test_bad_file_keeps_last_good():
    path = _fresh()
    _write(path, '{"guidance": {"law": "seed"}}')
    cfg, problems = C.load(path)
    eq(cfg["guidance"]["law"], "seed")
    eq(problems, [])
    _write(path, '{"guidance": {"law": "seed"')  # truncated write
    cfg, problems = C.load(path)
    eq(cfg["guidance"]["law"], "seed")  # the last good one, not the defaults
    true("rejected" in problems[0] and "last good" in problems[1], repr(problems))


def test_save_is_atomic_and_refuses_bad():
    path = _fresh()
    C.save(path, {"modes": {"xte_alarm_m": 3.0}})
    cfg, _ = C.load(path)
    eq(cfg["modes"]["xte_alarm_m"], 3.0)
    raises(C.ConfigError, C.save, path, {"modes": {"xte_alarm_m": "far"}})
    cfg, _ = C.load(path)
    eq(cfg["modes"]["xte_alarm_m"], 3.0)
    true("config.json.tmp" not in os.listdir(DIR))


def test_non_utf8_file_falls_back_and_never_raises():
    """Issue 14.5: a Latin-1 "Bär" as boat name used to raise UnicodeError at every boot."""
    path = _fresh()
    with open(path, "wb") as f:
        f.write(b'{"boat": {"name": "B\xe4r"}}')
    cfg, problems = C.load(path)
    eq(cfg, C.defaults())
    true(C.rejected(problems), problems)
    true("UTF-8" in "; ".join(problems), problems)
    # a good file afterwards is taken, and then a broken one falls back to it
    _write(path, '{"boat": {"name": "Baer"}}')
    cfg, problems = C.load(path)
    eq(cfg["boat"]["name"], "Baer")
    false_ = C.rejected(problems)
    eq(false_, False)
    with open(path, "wb") as f:
        f.write(b'\xff\xfe{"boat"')
    cfg, problems = C.load(path)
    eq(cfg["boat"]["name"], "Baer")
    true(C.rejected(problems), problems)


def test_sender_id_0_is_refused():
    """Issue 14.3: sender 0 is the pilot's own keypad; our keys must never look like it."""
    true(C.validate({"pilot": {"sender_id": 0}}), "sender 0 accepted")
    eq(C.validate({"pilot": {"sender_id": 1}}), [])


def test_secret_values_never_in_errors():
    """Issue 14.11: errors go to the log; a password must not."""
    errs = "; ".join(C.validate({"ntrip": {"password": 31415926, "port": 99999999},
                                 "hmi": {"key_file": 27182818}}))
    true("ntrip.password" in errs and "31415926" not in errs, errs)
    true("99999999" in errs, errs)  # ordinary values are still shown
    true("27182818" in errs, errs)  # key_file is a path, not a secret
    for name in ("password", "wifi_password", "api_key", "secret", "client_secret", "token", "key"):
        true(C.is_secret(name), name)
    for name in ("key_file", "user", "host", "keepalive_ms", "btn_ack"):
        eq(C.is_secret(name), False)
    path = _fresh()
    _write(path, '{"ntrip": {"password": 31415926}}')
    cfg, problems = C.load(path)
    true("31415926" not in "; ".join(problems), problems)
