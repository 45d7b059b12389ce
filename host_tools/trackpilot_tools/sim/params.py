"""Simulator parameters: boat_params.json beside this file, overlaid by user files and overrides."""
import copy
import json
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


def load(path=None, overrides=None):
    """Defaults (+ a partial JSON file) (+ a dict of overrides) -> parameter dict."""
    p = _strip(json.loads(DEFAULT_PATH.read_text()))
    if path:
        merge(p, json.loads(Path(path).read_text()))
    if overrides:
        merge(p, overrides)
    return p


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
