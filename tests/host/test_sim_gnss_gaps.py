"""Issue 12 through the whole firmware in the simulator: bridges (RTK float, no GNSS, single,
float, a bent compass), long dropouts, and receivers that send their messages in another order,
without NAV-EOE, at another rate or without answering the configuration."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.logdecode import decode_files  # noqa: E402
from trackpilot_tools.sim import benchtracks, scenarios, stcodec  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402

BRIDGE_T_S = 60.0  # float from here, the dropout 6 s later


@pytest.fixture(scope="module")
def canal(tmp_path_factory):
    # the canal: 300 m at 1.5 m/s
    return benchtracks.straight(str(tmp_path_factory.mktemp("tracks") / "canal.csv"), 1.5, 300.0)


def _bridge(canal, out, dropout_s, seed, law="los"):
    r = SimRun(canal, out, seed=seed, law=law, scenario="current",
               faults=scenarios.bridge_faults(BRIDGE_T_S, dropout_s),
               overrides=dict(scenarios.BRIDGE_GNSS))
    res = r.run()
    assert res["failure"] is None, res["failure"]
    modes = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    events = decode_files(sorted((Path(out) / "fw" / "log").glob("*.tpl"))).events
    return r, res, modes, events


def _max_xte_after_start(res):
    # from the bridge approach on (the first metres are the start-up, not this issue)
    return max(abs(x) for t, x, _, _, _ in res["truth_xte"] if t >= BRIDGE_T_S - 10)


def _drop_ms(dropout_start_s):
    return int((BRIDGE_T_S + 6.0) * 1000) if dropout_start_s is None else int(dropout_start_s * 1000)


# measured max |XTE| from the approach on, seeds 1-4, `los` (damped law of issue 10): 1.03, 0.83, 1.15, 1.44 m (goal 2.0)
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_bridge_completes_without_a_person(canal, tmp_path, seed):
    """Float 6 s, no GNSS 15 s, single 5 s, float 9 s, compass bent 6 deg: the same AUTO goes
    on (dead reckoning, then guidance by itself), the motor slowed within 0.5 s of the loss."""
    r, res, modes, events = _bridge(canal, tmp_path / "b", 15.0, seed)
    assert res["stop_reason"] == "finished", (res["stop_reason"], modes)
    assert r.engage_tries == 1  # one person's press for the whole run
    names = [v for _, v in modes]
    assert names[:2] == ["STANDBY", "AUTO"] and "AUTO(dead-reckoning)" in names
    assert "ALARM" not in names
    drop = _drop_ms(None)
    slowed = [t for t, rpm in res["motor_setpoints"] if t >= drop and rpm <= 200]
    assert slowed and slowed[0] - drop <= 500, res["motor_setpoints"][:6]
    texts = [e.text for e in events]
    assert any("quality" in x and "-> dead-reckoning" in x for x in texts), texts
    assert any("dead reckoning ended" in x for x in texts), texts
    assert _max_xte_after_start(res) <= 2.0


def test_30_s_dropout_completes(canal, tmp_path):
    """30 s without GNSS, then the 5 s single and 9 s float of reacquisition (measured: 1.70 m, seed 2)."""
    r, res, modes, events = _bridge(canal, tmp_path / "b", 30.0, seed=2)
    assert res["stop_reason"] == "finished", (res["stop_reason"], modes)
    assert "ALARM" not in [v for _, v in modes]
    assert _max_xte_after_start(res) <= 4.0


def test_60_s_dropout_alarm_and_pilot_holds_course(canal, tmp_path):
    r, res, modes, events = _bridge(canal, tmp_path / "b", 60.0, seed=2)
    names = [v for _, v in modes]
    assert "ALARM" in names and "STANDBY" not in names[2:], modes
    t_alarm = [t for t, v in modes if v == "ALARM"][0]
    drop_s = BRIDGE_T_S + 6.0
    assert 40.0 < t_alarm - drop_s < 41.0  # modes.gnss_hold_s (default 40 s)
    assert any("GNSS bad for more than 40 s" in e.text for e in events)
    assert not any(v.startswith("AUTO") for t, v in modes if t > t_alarm)  # only a person
    # the pilot keeps its course in Auto: no course key after the alarm
    assert r.pilot.mode == stcodec.MODE_AUTO
    assert r.pilot.last_course_key_ms is not None and r.pilot.last_course_key_ms < t_alarm * 1000 + 500


# (gnss parameters, what it is)
VARIANTS = [
    ({"order": "pvt_first", "eoe": False}, "NAV-PVT first, no NAV-EOE (the issue's report)"),
    ({"order": "pvt_first", "eoe": True}, "NAV-PVT first, NAV-EOE"),
    ({"order": "relpos_first", "eoe": True}, "NAV-PVT last, NAV-EOE"),
    ({"rate_hz": 10}, "10 Hz"),
    ({"rate_hz": 25, "order": "pvt_first"}, "25 Hz, NAV-PVT first"),
    ({"rate_hz": 1, "order": "pvt_first"}, "1 Hz, NAV-PVT first"),
    ({"answer_valset": False, "order": "pvt_first"}, "configuration not answered"),
]


@pytest.mark.parametrize("gnss,what", VARIANTS, ids=[w for _, w in VARIANTS])
def test_every_receiver_variant_engages_within_2_s(canal, tmp_path, gnss, what):
    r = SimRun(canal, tmp_path / "v", seed=5, scenario="calm", duration_s=20,
               overrides={"gnss": gnss, "sim": {"engage_delay_s": 0.2, "engage_retry_s": 0.5}})
    res = r.run()
    assert res["failure"] is None, res["failure"]
    modes = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    auto = [t for t, v in modes if v.startswith("AUTO")]
    assert auto and auto[0] <= 2.0, (what, modes)  # RTK fixed from the first epoch
    events = decode_files(sorted((tmp_path / "v" / "fw" / "log").glob("*.tpl"))).events
    texts = [e.text for e in events]
    rate = gnss.get("rate_hz", 5)
    assert any("receiver epoch interval %d ms" % (1000 // rate) in x for x in texts), texts
    cfg = [x for x in texts if x.startswith("receiver configuration")]
    if gnss.get("answer_valset", True):
        assert cfg and "done" in cfg[0], texts
    else:
        assert cfg and "FAILED" in cfg[0], texts


def test_bridge_with_a_10_hz_pvt_first_receiver_without_eoe(canal, tmp_path):
    """The same bridge, the receiver at 10 Hz in the real F9P's order without NAV-EOE
    (measured: 1.27 m)."""
    r = SimRun(canal, tmp_path / "b", seed=2, scenario="current",
               faults=scenarios.bridge_faults(BRIDGE_T_S, 15.0),
               overrides={"gnss": dict(scenarios.BRIDGE_GNSS["gnss"], rate_hz=10, order="pvt_first",
                                       eoe=False)})
    res = r.run()
    assert res["failure"] is None and res["stop_reason"] == "finished", res["stop_reason"]
    assert r.engage_tries == 1
    assert _max_xte_after_start(res) <= 2.0


def test_25_hz_steers_like_5_hz(tmp_path):
    """The law's time step is the measured epoch interval: a receiver left at 25 Hz steers as at
    5 Hz. Measured on 600 m in gusts, seed 1: 5 Hz 787 keys RMS 0.58 m; 25 Hz 799 keys RMS 0.56 m
    (with the fixed 0.2 s step: 1463 keys, RMS 1.73 m)."""
    import math

    track = benchtracks.straight(str(tmp_path / "s.csv"), 1.5, 600.0)
    got = {}
    for rate in (5, 25):
        r = SimRun(track, tmp_path / ("r%d" % rate), seed=1, scenario="gusts",
                   overrides={"gnss": {"rate_hz": rate}})
        res = r.run()
        assert res["stop_reason"] == "finished", res["stop_reason"]
        xs = [x for _, x, s, _, _ in res["truth_xte"] if s > 50]
        got[rate] = (r.pilot.keys_accepted, math.sqrt(sum(x * x for x in xs) / len(xs)))
    assert got[25][0] <= 1.15 * got[5][0], got
    assert got[25][1] <= got[5][1] + 0.1, got
    # the replay measures the step from the logged iTOWs as the app did: every command again
    from trackpilot_tools.replay_cmd import run_replay

    summary, _ = run_replay(sorted((tmp_path / "r25" / "fw" / "log").glob("*.tpl")),
                            config=tmp_path / "r25" / "config.json")
    assert summary["guided"] > 1000 and summary["heading_identical"] == summary["guided"], summary


# before the dead-reckoned step's heading was rounded to the log's resolution: 1196/1198 (seed 2)
# and 1147/1169 (seed 3) identical on the 64-bit port, 1194/1198 and 1148/1169 on float32
@pytest.mark.parametrize("seed", [2, 3])
def test_bridge_run_replays_every_command(canal, tmp_path, seed):
    """Dead-reckoned steps are logged as the position steered by: a replay reproduces them."""
    from trackpilot_tools.replay_cmd import run_replay

    r, res, modes, events = _bridge(canal, tmp_path / "b", 15.0, seed=seed)
    summary, _ = run_replay(sorted((tmp_path / "b" / "fw" / "log").glob("*.tpl")),
                            config=tmp_path / "b" / "config.json")
    assert summary["guided"] > 1000 and summary["heading_identical"] == summary["guided"], summary


@pytest.mark.parametrize("float_s", [60, 120])
def test_long_float_after_the_bridge(canal, tmp_path, float_s):
    """A float episode of 60 / 120 s after the bridge's 15 s dropout: steered on float (XTE
    alarm limit doubled), completes without a person (measured max |XTE| 0.83 m for both)."""
    faults = scenarios.bridge_faults(BRIDGE_T_S, 15.0) + ["rtk_float@%g:%g" % (BRIDGE_T_S + 21, float_s)]
    r = SimRun(canal, tmp_path / "f", seed=2, scenario="current", faults=faults,
               overrides=dict(scenarios.BRIDGE_GNSS))
    res = r.run()
    assert res["failure"] is None and res["stop_reason"] == "finished", res["stop_reason"]
    assert r.engage_tries == 1
    modes = [v for t, n, v in res["outputs"] if n == "mode"]
    assert "ALARM" not in modes
    assert _max_xte_after_start(res) <= 2.0


pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)
