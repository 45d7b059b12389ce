"""The example track, sailed end to end by the real firmware in the simulator: calm and with
current, both guidance laws. Reads the results the way `make sim` reports them."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.sim import report  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

TRACK = ROOT / "tracks" / "middelburg_loop.csv"


@pytest.mark.parametrize("law", ["los", "seed"])
@pytest.mark.parametrize("scenario", ["calm", "current"])
def test_example_track_completes(tmp_path, law, scenario):
    run = SimRun(TRACK, tmp_path, seed=11, law=law, scenario=scenario)
    res = run.run()
    summ = report.summarize_run(res, {})
    assert res["failure"] is None, res["failure"]
    assert summ["finished"], res["stop_reason"]
    modes = [v for _, n, v in res["outputs"] if n == "mode"]
    assert modes[-1].startswith("STANDBY") and any(m.startswith("AUTO") for m in modes)
    assert list((tmp_path / "fw" / "log").glob("*.tpl"))
    if law == "los":
        # the 180-degree bend alone costs about 2.6 m against the track as given (R = 9 m)
        xte = [abs(x) for _, x, _, _, _ in res["truth_xte"]]
        assert max(xte) < 4.0, max(xte)
        assert (sum(x * x for x in xte) / len(xte)) ** 0.5 < 1.0
