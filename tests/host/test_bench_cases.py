"""Issue 14: the fault matrix's combined cases (bench_faults.CASES) each run once through the
firmware in the simulator and meet their defined reaction."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools import bench_faults  # noqa: E402
from trackpilot_tools.sim import benchtracks  # noqa: E402


def test_every_simulator_fault_and_case_is_in_the_matrix():
    names, missing = bench_faults.fault_list()
    assert missing == []
    for case in ("race_takeover_vs_recovery", "sender0_config", "bad_config", "alarm_no_recovery"):
        assert case in names


@pytest.mark.parametrize("name", sorted(bench_faults.CASES))
def test_case_reaction(tmp_path, name):
    track = benchtracks.uturn(str(tmp_path / "u.csv"), 20, length_m=200.0)
    row = bench_faults.run_fault({"fault": name, "track": track, "out": str(tmp_path / name), "timeout": 120})
    assert row["failure"] is None, row
    assert row["reaction_ok"], row


def test_hand_remote_takeover_is_timed_from_the_remotes_key(tmp_path):
    """The fault matrix's remote_key_echo: armed at 40 s, the remote repeats the firmware's next
    keystroke, seconds later on a settled straight. The check timed the takeover from 40 s and
    called a 0.1 s takeover at 42.2 s 'no' (make bench: 29 of 30)."""
    track = benchtracks.uturn(str(tmp_path / "u.csv"), 20, length_m=200.0)
    row = bench_faults.run_fault({"fault": "remote_key_echo", "track": track, "out": str(tmp_path / "r"),
                                  "timeout": 120})
    assert row["failure"] is None, row
    assert row["reaction_ok"], row
    assert row["detect_s"] is not None and row["detect_s"] <= 0.5, row


pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)


def test_the_benchmark_mission_is_a_track_the_firmware_takes(tmp_path):
    """`make bench`'s compute and memory mission (the example loop three times): every name stays
    within the display's width once it carries its loop's number. It did not ('bridge_approach_0',
    17 characters), and the firmware refused the mission, so the full benchmark had no CPU, heap or
    log figures."""
    from trackpilot_tools import bench_perf
    from trackpilot_tools.sim.runner import _fw_import

    _fw_import()
    from trackpilot.nav.track import MAX_NAME_CHARS, parse_track_csv

    path = bench_perf.mission_track(str(tmp_path / "mission.csv"))
    text = Path(path).read_text()
    one = parse_track_csv((bench_perf.ROOT / "tracks" / "middelburg_loop.csv").read_text())
    trk = parse_track_csv(text)  # raises TrackError on a name too long
    assert len(trk.waypoints) > 2 * len(one.waypoints)
    names = [l.split(",")[3] for l in text.splitlines() if l and l[0] in "0123456789-"]
    assert all(len(n) <= MAX_NAME_CHARS for n in names)
    assert "bridge_approac_0" in names and "bridge_approac_2" in names
