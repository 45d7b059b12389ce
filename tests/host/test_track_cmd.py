"""`trackpilot track check` on the example track and on bad files (messages with line numbers)."""
import subprocess
import sys
from pathlib import Path

import pytest

from trackpilot_tools import cli

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "tracks" / "middelburg_loop.csv"

HEADER = "lon,lat,speed_mps,name,radius_m\n"
GOOD_ROWS = "3.6100000,51.4900000,1.5,a,\n3.6100000,51.4909000,2.0,b,\n"


def run_check(capsys, *args):
    rc = cli.main(["track", "check", *map(str, args)])
    out, err = capsys.readouterr()
    return rc, out, err


def test_example_track_leg_table(capsys):
    rc, out, err = run_check(capsys, EXAMPLE)
    assert rc == 0, err
    assert "13 waypoints, 12 legs" in out
    assert "bend_in            bend_out                20.0    180.0     +90.0" in out
    assert "total length 1948.4 m, expected duration" in out
    assert "2 warnings (turning radius 9.0 m)" in out
    assert "wp 5 'bend_in' (line 11): 90 deg turn" in out and "expect 2.6 m off the track" in out
    rc, out, _ = run_check(capsys, EXAMPLE, "--strict")
    assert rc == 2
    rc, out, _ = run_check(capsys, EXAMPLE, "--turn-radius", "4")
    assert rc == 0 and "no warnings (turning radius 4.0 m)" in out


def test_installed_command_runs():
    proc = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "track", "check", str(EXAMPLE)],
                          capture_output=True, text=True, cwd=str(ROOT / "host_tools"))
    assert proc.returncode == 0, proc.stderr
    assert "leg  from" in proc.stdout


@pytest.mark.parametrize("body, line, words", [
    ("", 1, "no header line"),
    (HEADER + "3.61,51.49,1,a,\n", 2, "at least 2 waypoints, found 1"),
    (HEADER + GOOD_ROWS + "3.61,51.4x,1,c,\n", 4, "lat '51.4x' is not a decimal number"),
    (HEADER + GOOD_ROWS + "3.61,95.0,1,c,\n", 4, "lat 95.0 is out of range"),
    (HEADER + GOOD_ROWS + "# comment\n3.61,51.492,-0.5,c,\n", 5, "speed_mps -0.5 is negative"),
    (HEADER + GOOD_ROWS + "3.61,51.492,15,c,\n", 4, "above 8.0 m/s"),
    (HEADER + GOOD_ROWS + "3.6100000,51.4909000,1,c,\n", 4, "repeats the previous point (line 3)"),
    (HEADER + GOOD_ROWS + "3.6100000,51.4909300,1,c,\n", 4, "3.3 m long; legs shorter than 5.0 m"),
    ("lon,lat,speed\n" + GOOD_ROWS, 1, "unknown column 'speed'"),
    (HEADER + GOOD_ROWS + "3.61,51.492,1,c,0\n", 4, "radius_m 0 must be in (0, 500] m"),
])
def test_bad_files(tmp_path, capsys, body, line, words):
    p = tmp_path / "bad.csv"
    p.write_text(body)
    rc, out, err = run_check(capsys, p)
    assert rc == 1
    assert out == ""
    assert err.startswith("%s: line %d: " % (p, line)), err
    assert words in err, err


def test_missing_file(tmp_path, capsys):
    rc, _, err = run_check(capsys, tmp_path / "nope.csv")
    assert rc == 1 and "nope.csv" in err


def test_min_leg_option(tmp_path, capsys):
    p = tmp_path / "short.csv"
    p.write_text(HEADER + GOOD_ROWS + "3.6100000,51.4909300,1,c,\n")
    rc, out, err = run_check(capsys, p, "--min-leg", "2")
    assert rc == 0, err
    assert "3 waypoints, 2 legs" in out
