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
