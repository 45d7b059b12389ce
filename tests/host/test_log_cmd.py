"""`trackpilot log decode/plot` and the summary the simulator reuses."""
import csv
import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "firmware"))

from trackpilot.record import logfmt as L  # noqa: E402
from trackpilot_tools import cli  # noqa: E402
from trackpilot_tools.logdecode import (  # noqa: E402
    decode_files, lat_lon_deg_text, summarize)

from logseq import write_log  # noqa: E402


@pytest.fixture(scope="module")
def logdir(tmp_path_factory):
    d = tmp_path_factory.mktemp("log")
    write_log(str(d), 2500, max_file_bytes=30000)
    return d


def test_decode_prints_summary_events_and_writes_csv(logdir, tmp_path, capsys):
    files = [str(p) for p in sorted(logdir.iterdir(), reverse=True)]  # order does not matter
    out = tmp_path / "run.csv"
    assert cli.main(["log", "decode"] + files + ["--csv", str(out), "--events"]) == 0
    text = capsys.readouterr().out
    assert "session 1 part 0" in text and "reset power_on" in text
    assert "mode_changes           3" in text
    assert "STANDBY->AUTO: engaged from HMI" in text
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 2500
    d = decode_files(files)
    assert [int(r["lat_e7"]) for r in rows] == [c.lat_e7 for c in d.controls]
    assert rows[10]["lat_deg"] == lat_lon_deg_text(d.controls[10].lat_e7, d.controls[10].lat_hp)
    t = [float(r["t_s"]) for r in rows]
    assert all(0.15 < b - a < 0.25 for a, b in zip(t, t[1:]))  # across the tick wrap


def test_plot_writes_pngs(logdir, tmp_path, capsys):
    out = tmp_path / "plots"
    assert cli.main(["log", "plot"] + [str(p) for p in logdir.iterdir()] + ["--out", str(out)]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["heading.png", "speed.png", "track.png", "xte.png"]
    for p in out.iterdir():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 20000


def test_bad_input_gives_clear_errors(tmp_path, capsys):
    assert cli.main(["log", "decode", str(tmp_path / "missing.tpl")]) == 2
    assert "cannot read" in capsys.readouterr().err
    junk = tmp_path / "junk.tpl"
    junk.write_bytes(b"hello, not a log\n" * 50)
    assert cli.main(["log", "plot", str(junk), "--out", str(tmp_path / "o")]) == 2
    assert "no trackpilot log records" in capsys.readouterr().err


def test_summarize_numbers():
    enc = L.LogEncoder()
    data = bytearray(enc.header())
    xs = [0.5, -1.0, 2.0, -0.25, 3.0]
    for k, x in enumerate(xs):
        r = L.ControlRecord()
        r.t_ms = 1000 + 200 * k
        r.pos_valid = True
        r.lat_e7 = 514950000 + 90 * k  # about 1.0 m north per record
        r.lon_e7 = 36100000
        r.xte_m = x
        r.mode = 1 if k < 4 else 0  # the last record is not in AUTO
        r.keys_sent = 3 * k
        r.alarms = 64 if k == 2 else 0
        data += enc.encode_control(r)
        if k == 4:
            data += enc.encode_event("MODE", "AUTO->STANDBY: test", r.t_ms)
    s = summarize(L.iter_records(bytes(data)))
    auto = xs[:4]
    assert s["xte_rms_m"] == round(math.sqrt(sum(x * x for x in auto) / 4), 3)
    assert s["xte_max_abs_m"] == 2.0
    assert s["keystrokes"] == 12
    assert s["alarms"] == ["xte"]
    assert s["mode_changes"] == 1
    assert abs(s["distance_m"] - 4 * 90 * 0.0111195) < 0.05
    assert s["control_records"] == 5
    assert s["duration_s"] == 0.8 and s["auto_s"] == 0.8
