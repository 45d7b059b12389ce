"""`trackpilot replay LOG --closed-loop`: a simulator run's log re-sailed from its AUTO start state
gives close figures with the same law on the same boat, different ones with another law, and a
plain error for a log without AUTO or without a track."""
import json

import pytest

from trackpilot_tools import cli
from trackpilot_tools.errors import UserError
from trackpilot_tools.sim import benchtracks
from trackpilot_tools.sim.runner import SimRun

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON


def _cli(argv):
    try:
        return cli.main(argv)
    except SystemExit as e:
        return e.code


@pytest.fixture(scope="module")
def logged_run(tmp_path_factory):
    base = tmp_path_factory.mktemp("logged")
    track = benchtracks.zigzag(str(base / "zz.csv"), 40, leg_m=60.0, legs=4)
    run = SimRun(track, base / "run", seed=1, law="los", scenario="calm")
    run.run()
    return sorted((base / "run" / "fw" / "log").glob("*.tpl"))


def test_same_law_close_other_law_differs(logged_run, tmp_path, capsys):
    logs = [str(p) for p in logged_run]
    assert _cli(["replay", *logs, "--closed-loop", "--out", str(tmp_path / "a")]) == 0
    same = json.loads((tmp_path / "a" / "replay_closed.json").read_text())
    assert (tmp_path / "a" / "replay_closed.png").is_file()
    a, b = same["logged"], same["resailed"]
    assert same["along_track_m"] > 200
    assert b["rms_m"] == pytest.approx(a["rms_m"], rel=0.3, abs=0.1)
    assert b["max_m"] == pytest.approx(a["max_m"], rel=0.4, abs=0.3)
    assert b["keys"] == pytest.approx(a["keys"], rel=0.3)
    assert _cli(["replay", *logs, "--closed-loop", "--law", "seed", "--out", str(tmp_path / "b"),
                 "--no-plot"]) == 0
    other = json.loads((tmp_path / "b" / "replay_closed.json").read_text())
    assert other["resailed"]["law"] == "seed"
    assert other["logged"] == a
    assert abs(other["resailed"]["rms_m"] - a["rms_m"]) > 2 * abs(b["rms_m"] - a["rms_m"]) + 0.1
    text = capsys.readouterr().out
    assert "re-sailed (seed)" in text and "keystrokes" in text


def test_log_without_auto_is_a_plain_error(tmp_path, capsys):
    track = benchtracks.straight(str(tmp_path / "s.csv"), 2.0)
    run = SimRun(track, tmp_path / "run", seed=1, scenario="calm", duration_s=2.0)  # ends before ENGAGE
    run.run()
    logs = [str(p) for p in sorted((tmp_path / "run" / "fw" / "log").glob("*.tpl"))]
    rc = _cli(["replay", *logs, "--closed-loop", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2
    assert "never was in AUTO" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists() and not (tmp_path / "o.partial").exists()


def test_log_without_track_is_a_plain_error(logged_run):
    from trackpilot_tools import logdecode, replay_closed

    d = logdecode.decode_files(logged_run)
    d.track = None
    with pytest.raises(UserError, match="no track record"):
        replay_closed.auto_span(d)
