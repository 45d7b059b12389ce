"""The track memory budget (nav/track.py TRACK_BUDGET_B, tracks/README.md, docs/MEMORY.md): a track
whose heap on the ESP32 (track_heap_bytes) passes it is refused by `track check` and `upload`
with the line where it does and what to do; a track just inside is accepted; a name longer than
the display's 16 columns is refused. The firmware's refusal: tests/mpy/test_app_track_load.py;
the estimate against the measured heap: tests/mpy/test_track_compact.py; the heap the app keeps
with a track at the budget: tests/host/test_frozen_heap.py."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
sys.path.insert(0, str(ROOT / "firmware"))
sys.path.insert(0, str(ROOT / "firmware" / "tools"))
from trackpilot_tools import cli  # noqa: E402
from trackpilot_tools.device_cmd import DeviceError  # noqa: E402
from trackpilot_tools.upload_cmd import check_track  # noqa: E402
from trackpilot.nav import track  # noqa: E402
import track_heap  # noqa: E402


def test_2000_waypoints_without_names_inside_the_budget(tmp_path):
    path = tmp_path / "plain.csv"
    track_heap.write_named_track(str(path), track.MAX_WAYPOINTS)
    assert track_heap.track_esp32_b(str(path)) <= track.TRACK_BUDGET_B - 4096  # room left for names
    assert cli.main(["track", "check", str(path)]) == 0


def test_just_inside_accepted_just_over_refused_at_the_crossing_line(tmp_path, capsys):
    inside = tmp_path / "inside.csv"
    over = tmp_path / "over.csv"
    est_in = track_heap.write_budget_track(str(inside), track.MAX_WAYPOINTS)
    est_over = track_heap.write_budget_track(str(over), track.MAX_WAYPOINTS, over=True)
    assert track.TRACK_BUDGET_B - 256 < est_in <= track.TRACK_BUDGET_B < est_over, (est_in, est_over)
    assert cli.main(["track", "check", str(inside)]) == 0
    assert "2000 waypoints, 1999 legs" in capsys.readouterr().out
    trk, _ = check_track(str(inside))
    assert len(trk.waypoints) == 2000

    rc = cli.main(["track", "check", str(over)])
    err = capsys.readouterr().err
    assert rc == 1
    assert "B a track may take (tracks/README.md): shorten the names or split the track" in err, err
    assert "Traceback" not in err
    line = int(err.split("line ")[1].split(":")[0])
    with pytest.raises(DeviceError, match="line %d: the track up to here needs .*split the track; not uploaded"
                       % line):
        check_track(str(over))
    # the line is where the budget is crossed: the file cut just before it passes, with it not
    lines = over.read_text().splitlines(True)
    (tmp_path / "before.csv").write_text("".join(lines[: line - 1]))
    (tmp_path / "upto.csv").write_text("".join(lines[:line]))
    check_track(str(tmp_path / "before.csv"))
    with pytest.raises(DeviceError, match="line %d: the track up to here" % line):
        check_track(str(tmp_path / "upto.csv"))


def test_2000_waypoints_with_radii_fit_with_names_not(tmp_path, capsys):
    """An arrival radius costs 2 B per waypoint, a name column 2 B and the name's bytes: 2000
    waypoints with a radius each fit, with a name each too they do not; 1000 with both do."""
    path = tmp_path / "radii.csv"
    track_heap.write_named_track(str(path), 2000, radii=True)
    assert cli.main(["track", "check", str(path)]) == 0
    track_heap.write_named_track(str(path), 2000, name_chars=3, radii=True)
    assert cli.main(["track", "check", str(path)]) == 1
    assert "shorten the names or split the track" in capsys.readouterr().err
    track_heap.write_named_track(str(path), 1000, name_chars=8, radii=True)
    assert cli.main(["track", "check", str(path)]) == 0


def test_long_name_refused(tmp_path, capsys):
    path = tmp_path / "long.csv"
    path.write_text("lon,lat,speed_mps,name\n3.61,51.49,1.5,start\n3.6101,51.4901,1.5,a name of 17 chars\n")
    assert cli.main(["track", "check", str(path)]) == 1
    err = capsys.readouterr().err
    assert "line 3: name 'a name of 17 chars' has 18 characters: the most is 16 (the display's width)" in err, err
    with pytest.raises(DeviceError, match="line 3: name .* the most is 16.*not uploaded"):
        check_track(str(path))
    path.write_text("lon,lat,speed_mps,name\n3.61,51.49,1.5,start\n3.6101,51.4901,1.5,sixteen chars ok\n")
    assert cli.main(["track", "check", str(path)]) == 0


def test_import_cuts_long_names(tmp_path):
    from trackpilot_tools.track_import import import_track

    src = tmp_path / "points.csv"
    src.write_text("lat,lon,name\n51.4900,3.6100,the start by the bridge\n51.4910,3.6110,end\n")
    text, trk, _ = import_track(str(src))
    assert trk.waypoints[0].name == "the start by the"  # 16 characters
    assert trk.waypoints[1].name == "end"


def test_estimate_is_the_esp32_layout_everywhere():
    """The budget limits the ESP32's figure (32-bit words, float32) on every interpreter: the
    default arguments; and it grows with each input as the layout says."""
    pages = [128] * 15 + [80]  # 2000 waypoints, every name 1 byte
    base = track.track_heap_bytes(2000, [0] * 16, 1, False)
    assert base == track.track_heap_bytes(2000, [0] * 16, 1, False, 4, 4)
    radii = track.track_heap_bytes(2000, [0] * 16, 1, True) - base
    assert 2 * 2000 <= radii <= 2 * 2000 + 16 * 16 + 128, radii  # 2 B each, a 16 B header a page
    named = track.track_heap_bytes(2000, pages, 1, False) - base
    assert named == radii + 2000 + 16 * 16 + (16 + 64), named  # name ends, the names, their list
    assert track.track_heap_bytes(2000, [0] * 16, 1, False, 8, 8) > base
