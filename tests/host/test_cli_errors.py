"""Every everyday CLI mistake gives one clear line on stderr and a non-zero exit, never a traceback."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TRACK = str(ROOT / "tracks" / "middelburg_loop.csv")


def _files(tmp):
    bad_track = tmp / "bad.csv"
    bad_track.write_text("lat,lon\nfoo,bar\n")
    garbage = tmp / "garbage.tpl"
    garbage.write_bytes(bytes(range(256)) * 16)
    not_json = tmp / "params.json"
    not_json.write_text("{nope")
    bad_cfg = tmp / "bad_config.json"
    bad_cfg.write_text('{"guidance": {"los_clip_deg": 1000}}')
    nan_cfg = tmp / "nan_config.json"
    nan_cfg.write_text('{"guidance": {"los_clip_deg": NaN}}')
    return {"BAD": str(bad_track), "GARBAGE": str(garbage), "NOTJSON": str(not_json),
            "BADCFG": str(bad_cfg), "NANCFG": str(nan_cfg)}


# (argv, a fragment the one line must contain)
CASES = [
    (["sim", "nope.csv"], "no such track file"),
    (["sim", "{BAD}"], "header lacks the column"),
    (["sim", TRACK, "--fault", "nosuchfault@10"], "unknown name 'nosuchfault'"),
    (["sim", TRACK, "--fault", "gnss_dropout"], "gnss_dropout@T:D"),
    (["sim", TRACK, "--fault", "gnss_dropout@soon:5"], "must be numbers"),
    (["sim", TRACK, "--fault", "rtk_float@10"], "needs a duration"),
    (["sim", TRACK, "--fw-set", "guidance.nope=1"], "guidance.nope: unknown setting"),
    (["sim", TRACK, "--fw-set", "guidance"], "expected SECTION.KEY=VALUE"),
    (["sim", TRACK, "--fw-set", "guidance.law=zigzag"], "guidance.law"),
    (["sim", TRACK, "--set", "boat.nope=1"], "unknown simulator parameter boat.nope"),
    (["sim", TRACK, "--params", "/nonexistent/p.json"], "no such parameter file"),
    (["sim", TRACK, "--fw-config", "/nonexistent/config.json"], "no such firmware config file"),
    (["bench", "--robust", "0"], "must be at least 1 boat"),
    (["sim", TRACK, "--params", "{NOTJSON}"], "not a JSON parameter file"),
    (["sim", TRACK, "--duration-s", "-5"], "--duration-s must be > 0"),
    (["sim", TRACK, "--start-offset-m", "nan"], "start_offset_m=NaN: a finite number is needed"),
    (["sim", TRACK, "--current-mps", "1e9"], "--current-mps / water.current_mps 1000000000.0: outside 0..3"),
    (["sim", TRACK, "--wave-yaw-deg", "-3"], "outside 0..30"),
    (["sim", TRACK, "--reengage-s", "nan"], "--reengage-s must be seconds >= 0"),
    (["sim", TRACK, "--set", "boat.k_prime=nan"], 'boat.k_prime="nan": a finite number is needed'),
    (["sim", TRACK, "--set", "gnss.latency_ms=5"], "a list of finite numbers is needed, like [50, 100]"),
    (["bench", "--robust-one", "-3", "--case", "straight_1.0"], "--robust-one B: B is a boat of the sweep"),
    (["bench", "--seeds", "0"], "--seeds must be at least 1"),
    (["bench", "--jobs", "0"], "--jobs must be at least 1 worker"),
    (["bench", "--run-timeout", "nan"], "--run-timeout must be seconds > 0"),
    (["bench", "--robust", "2", "--robust-seed", "-5"], "--robust-seed S: the first boat"),
    (["monitor", "--stale-s", "nan", "--count", "1"], "--stale-s must be seconds > 0"),
    (["monitor", "--duration", "-5"], "--duration must be seconds >= 0"),
    (["monitor", "--count", "-1"], "--count must be datagrams >= 0"),
    (["monitor", "--web", "--history-s", "nan", "--duration", "1"], "--history-s must be seconds > 0"),
    (["replay", "nope.tpl"], "no such log"),
    (["replay", "{GARBAGE}"], "no trackpilot log records"),
    (["replay", "{GARBAGE}", "--set", "guidance.x=1"], "guidance.x: unknown setting"),
    (["replay", "{GARBAGE}", "--config", "/nonexistent/c.json"], "no such configuration file"),
    (["replay", "{GARBAGE}", "--config", "{BADCFG}"], "guidance.los_clip_deg: 1000 out of range"),
    (["replay", "{GARBAGE}", "--config", "{NANCFG}"], "guidance.los_clip_deg: nan out of range"),
    (["replay", "{GARBAGE}", "--config", "{NOTJSON}"], "not valid JSON"),
    (["hmi", "preview", "--sample", "nope", "--out", "{TMP}/h"], "no sample 'nope'"),
    (["hmi", "preview", "--status", "/nonexistent/s.json", "--out", "{TMP}/h"], "No such file"),
    (["log", "decode", "nope.tpl"], "cannot read nope.tpl"),
    (["log", "plot", "{GARBAGE}", "--out", "{TMP}/p"], "no trackpilot log records"),
    (["gnss", "decode", "nope.ubx"], "no such capture file"),
    (["seatalk", "decode", "nope.bin"], "no such capture file"),
    (["track", "check", "nope.csv"], "No such file"),
    (["track", "check", "{BAD}"], "header lacks the column"),
    (["monitor", "--serial", "/dev/nonexistent-port", "--count", "1"], "cannot open serial port"),
    (["monitor", "--udp", "99999", "--count", "1"], "a port is 1..65535"),
    (["monitor", "--web", "--http-port", "70000", "--duration", "1"], "a port is 1..65535"),
    (["monitor", "--web", "--track", "/nonexistent/t.csv", "--duration", "1"], "cannot read track"),
    (["sim", TRACK, "--udp-out", "--udp-port", "0"], "must be a UDP port"),
]


@pytest.mark.parametrize("argv,fragment", CASES, ids=[" ".join(c[0][:3]).replace(TRACK, "TRACK") for c in CASES])
def test_mistake_is_one_line(tmp_path, argv, fragment):
    subs = dict(_files(tmp_path), TMP=str(tmp_path))
    argv = [a.format(**subs) for a in argv]
    r = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli"] + argv, capture_output=True,
                       text=True, timeout=120, cwd=str(tmp_path))
    err_lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode != 0, r.stdout + r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    assert len(err_lines) == 1, r.stderr
    assert fragment in err_lines[0], err_lines[0]
    assert not (tmp_path / "sim_out").exists()  # a refused run writes nothing
