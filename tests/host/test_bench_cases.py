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


pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)
