"""Simulator parameters: boat_params.json beside this file, overlaid by user files and overrides."""
import copy
import json
import math
from pathlib import Path

DEFAULT_PATH = Path(__file__).with_name("boat_params.json")


def _strip(d):
    """Drop documentation keys (_about, _sources)."""
    if isinstance(d, dict):
        return {k: _strip(v) for k, v in d.items() if not k.startswith("_")}
    return d


def merge(base, over, where=""):
    """Overlay `over` on `base` in place; unknown keys are errors (a typo must not be ignored)."""
    for k, v in over.items():
        if k.startswith("_"):
            continue
        if k not in base:
            raise KeyError("unknown simulator parameter %s%s" % (where, k))
        if isinstance(base[k], dict) and isinstance(v, dict):
            merge(base[k], v, where + k + ".")
        else:
            base[k] = copy.deepcopy(v)
    return base


def merge_new(base, over):
    """Overlay `over` on `base` in place, creating sections (no check: load() checks later)."""
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            merge_new(base[k], v)
        else:
            base[k] = copy.deepcopy(v)
    return base


def load(path=None, overrides=None):
    """Defaults (+ a partial JSON file) (+ a dict of overrides) -> parameter dict (the nominal
    boat: the "spread" section is not a parameter, see load_spread)."""
    p = _strip(json.loads(DEFAULT_PATH.read_text()))
    if path:
        merge(p, json.loads(Path(path).read_text()))
    if overrides:
        merge(p, overrides)
    p.pop("spread", None)
    return p


SPREAD_KINDS = ("scale", "uniform", "latency")


def load_spread(path=None):
    """The "spread" section (+ a partial file's): {"section.key": {"kind", "range", "why"}}, checked."""
    raw = json.loads(DEFAULT_PATH.read_text())
    sp = _strip(raw["spread"])
    if path:
        merge(sp, _strip(json.loads(Path(path).read_text())).get("spread", {}), "spread.")
    nominal = load(path)
    for name, spec in sp.items():
        sec, _, key = name.partition(".")
        if sec not in nominal or key not in nominal[sec]:
            raise KeyError("spread: %s is not a simulator parameter" % name)
        lo, hi = spec["range"]
        if spec["kind"] not in SPREAD_KINDS or not lo <= hi or (spec["kind"] == "scale" and lo <= 0):
            raise ValueError("spread: %s: kind one of %s, range [lo, hi] (lo > 0 for scale)" % (name, SPREAD_KINDS))
    return sp


def draw_spread(boat_seed, spread, nominal):
    """One random boat: (overrides dict for merge, flat {"section.key": value}). Each parameter is
    drawn from its own generator (the boat seed and the parameter's name), so adding a range to
    the spread never changes the other parameters' draws."""
    from .randproc import component_rng

    over, flat = {}, {}
    for name in sorted(spread):
        spec = spread[name]
        sec, _, key = name.partition(".")
        rng = component_rng(boat_seed, "spread/" + name)
        lo, hi = spec["range"]
        kind = spec["kind"]
        if kind == "scale":
            f = math.exp(rng.uniform(math.log(lo), math.log(hi)))
            v = nominal[sec][key] * f
            if isinstance(nominal[sec][key], int):
                v = int(round(v))
            flat[name] = round(v, 4)
        elif kind == "uniform":
            v = rng.uniform(lo, hi)
            if isinstance(nominal[sec][key], int):
                v = int(round(v))
            flat[name] = round(v, 4)
        else:  # latency: a mean, the receiver's jitter band around it
            mean = rng.uniform(lo, hi)
            v = [round(mean * 2.0 / 3.0, 1), round(mean * 4.0 / 3.0, 1)]
            flat[name] = round(mean, 1)
        over.setdefault(sec, {})[key] = v
    return over, flat


def parse_set(items):
    """["boat.k_prime=1.0", ...] -> nested dict (values parsed as JSON when they parse).
    ValueError for an item that is not SECTION.KEY=VALUE."""
    out = {}
    for item in items or ():
        key, eq, text = item.partition("=")
        if not eq or "." not in key or not all(key.split(".")):
            raise ValueError("%r: expected SECTION.KEY=VALUE, e.g. pilot.deadband_deg=3" % item)
        try:
            value = json.loads(text)
        except ValueError:
            value = text
        d = out
        parts = key.split(".")
        for part in parts[:-1]:
            d = d.setdefault(part, {})
        d[parts[-1]] = value
    return out
