"""End to end: the real firmware (firmware/sim_main.py under the MicroPython unix port) sails
against the simulated boat. Short runs; reactions are read from the firmware's own outputs and log."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.sim import benchtracks, report  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    return benchtracks.straight(str(tmp_path_factory.mktemp("tracks") / "straight.csv"), 2.0, 300.0)


def sail(track, out, **kw):
    r = SimRun(track, out, **kw)
    res = r.run()
    summ = report.summarize_run(res, {})
    return r, res, summ


def modes(res):
    return [v for _, n, v in res["outputs"] if n == "mode"]


@pytest.mark.parametrize("law", ["seed", "los"])
def test_straight_in_cross_current_completes(straight, tmp_path, law):
    r, res, summ = sail(straight, tmp_path / law, law=law, seed=2, scenario="current",
                        overrides={"sim": {"start_offset_m": 3.0}})
    assert res["failure"] is None, res["failure"]
    assert summ["finished"], (res["stop_reason"], modes(res))
    assert any(m.startswith("AUTO") for m in modes(res))
    assert summ["firmware_log_files"]
    # after the first 100 m (settling from the offset while speeding up): bounded; the seed law
    # keeps its known steady offset in a cross current (about beta / k_y = 1.6 m here)
    later = [x for _, x, s, _, _ in res["truth_xte"] if s > 100.0]
    assert later and max(abs(x) for x in later) < 2.5
    # simulation speed is a benchmark figure (trackpilot bench), not a wall-clock test


def test_same_seed_same_truth_with_the_firmware(straight, tmp_path):
    for n in ("a", "b"):
        sail(straight, tmp_path / n, seed=5, scenario="gusts", duration_s=60)
    assert (tmp_path / "a" / "truth.csv").read_text() == (tmp_path / "b" / "truth.csv").read_text()


def test_person_key_on_the_pilot_ends_auto(straight, tmp_path):
    r, res, summ = sail(straight, tmp_path / "k", seed=3, faults=["pilot_key_minus10@40"], duration_s=60)
    ms = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    auto_t = [t for t, v in ms if v.startswith("AUTO")]
    assert auto_t and auto_t[0] < 40
    after = [v for t, v in ms if t >= 40]
    assert after and not after[-1].startswith("AUTO")
    assert r.pilot.keys_by_sender.get(0) is None  # the unit's own key, not a bus key it heard
    assert r.pilot.course_deg is not None


def test_reset_mid_track_restarts_in_standby(straight, tmp_path):
    r, res, summ = sail(straight, tmp_path / "r", seed=4, faults=["reset@40"], duration_s=70)
    assert res["resets"] == 1 and res["failure"] is None
    ms = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    assert [v for t, v in ms if t >= 40][0].startswith("STANDBY")
    assert not any(v.startswith("AUTO") for t, v in ms if t >= 40)  # never engages by itself


def _fault_run(straight, tmp_path, fault, duration_s=80):
    r, res, summ = sail(straight, tmp_path / "f", seed=3, scenario="current", faults=[fault],
                        duration_s=duration_s)
    assert res["failure"] is None, res["failure"]
    return r, res, [(t, v) for t, n, v in res["outputs"] if n == "mode"]


# (fault, the modes the firmware must show after it, in order) -- ARCHITECTURE.md "Modes and safety"
REACTIONS = [
    # GNSS gaps inside AUTO (docs/MODES.md "GNSS gaps"): dead reckoning, then guidance again by
    # itself; 30 s of single count 7.5 s of the 40 s hold (its Doppler velocity); the hold's
    # ALARM is in test_sim_gnss_gaps.py
    ("rtk_single@40:30", ["AUTO(dead-reckoning)", "AUTO"]),
    ("gnss_dropout@40:4", ["AUTO(dead-reckoning)", "AUTO"]),
    ("heading_loss@40:4", ["AUTO(dead-reckoning)", "AUTO"]),
    ("pilot_hang_keys@40", ["AUTO(recovering)", "AUTO"]),
    ("pilot_silent@40:20", ["AUTO(recovering)"]),
    ("motor_link_loss@40:20", ["ALARM"]),
    ("estop@40:10", ["ESTOP"]),
    ("button_standby@40", ["STANDBY"]),
    # keeps talking, stops steering: found by the heading not turning towards the locked course
    # while the app keeps stepping it (st2000.py check (c)); 23.8 s after the fault with seed 3
    ("pilot_hang_steer@40", ["AUTO(recovering)", "AUTO"]),
    # 3 % of characters corrupted: an unasked mode in one status is not a takeover
    ("st_noise@40:40", []),
    # lost echo: the firmware cannot send keys, so it cannot steer: SeaTalk alarm, then ALARM
    ("st_tx_lost@40:20", ["ALARM"]),
]


@pytest.mark.parametrize("fault,expect", REACTIONS)
def test_fault_reaction(straight, tmp_path, fault, expect):
    r, res, ms = _fault_run(straight, tmp_path, fault)
    after = [v for t, v in ms if t >= 40.0]
    got = []
    for v in after:  # the expected modes must appear in this order
        if len(got) < len(expect) and v == expect[len(got)]:
            got.append(v)
    assert got == expect, after
    if not expect:  # no reaction expected: it stays in AUTO (st_noise: no takeover, no Standby,
        # no ALARM, and no hang recovery: on a noisy bus hang rule (a) needs 6 lost keys, not 3;
        # seed 3 recovered once before that, docs/SEATALK.md)
        assert not after, after


AL_SEATALK = 1024  # firmware/trackpilot/core/modes.py


def test_pilot_hang_keys_found_on_a_noisy_bus(straight, tmp_path):
    # the pilot ignores keys from 40 s on a bus with 3 % of its characters corrupted since 30 s:
    # hang rule (a) then needs 6 lost keys in a row (9.7-11.1 s after the hang on seeds 1-4, 5.2 s
    # on a quiet bus)
    r, res, summ = sail(straight, tmp_path / "hn", seed=2, scenario="current",
                        faults=["pilot_hang_keys@40", "st_noise@30:50"], duration_s=80)
    assert res["failure"] is None, res["failure"]
    ms = [(t, v) for t, n, v in res["outputs"] if n == "mode" and t >= 30]
    hang = [t for t, v in ms if v == "AUTO(recovering)"]
    assert hang and 40 < hang[0] < 40 + 20, ms
    assert ms[-1][1] == "AUTO", ms


def test_pilot_hang_steer_detected_in_bounded_time(straight, tmp_path):
    r, res, ms = _fault_run(straight, tmp_path, "pilot_hang_steer@40", duration_s=110)
    hang = [t for t, v in ms if v == "AUTO(recovering)"]
    # the course error builds ~15-20 s (the 6 s x U lookahead of issue 10 asks for the course
    # back more gently than the old 3 s: ~8 s then), then one 15 s window
    assert hang and 40 < hang[0] < 40 + 45, ms
    assert any(v == "AUTO" for t, v in ms if t > hang[0])
    assert r.pilot.hang is None  # Standby then Auto cleared it
    later = [abs(x) for t, x, s, _, _ in res["truth_xte"] if t > hang[0] + 20]
    assert later and max(later) < 10.0  # back on track, not 80 m off


def test_lost_echo_alarm_then_clears_without_reengaging(straight, tmp_path):
    r, res, summ = sail(straight, tmp_path / "f", seed=3, scenario="current",
                        faults=["st_tx_lost@40:20", "button_standby@70"], duration_s=80)
    assert res["failure"] is None, res["failure"]
    ms = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    alarm = [t for t, v in ms if v == "ALARM" and t >= 40]
    assert alarm and alarm[0] < 40 + 5.0, ms  # bounded: 3 datagrams or 5 s
    assert not any(v.startswith("AUTO") for t, v in ms if t > alarm[0])  # never by itself
    alarms = [(t, n, v) for t, n, v in res["outputs"] if n == "alarms"]
    on = [t for t, n, v in alarms if int(v) & AL_SEATALK]
    assert on and 40 < on[0] <= alarm[0] + 0.01, alarms
    # in ALARM the driver sends nothing on its own (issue 14.1): the alarm stays until a
    # datagram goes out again, here the Standby of the person's STANDBY at 70 s
    assert int([v for t, n, v in alarms if t < 70][-1]) & AL_SEATALK, alarms
    assert not int(alarms[-1][2]) & AL_SEATALK, alarms


@pytest.mark.parametrize("rx_timeout_chars,echo_timeout_ms,works", [
    (10, None, True),  # ESP-IDF's default RX timeout with the configured echo timeout (40 ms)
    (1, None, True),  # what wiring_esp32 asks for (timeout_char=1)
    (10, 10, False),  # the old 10 ms echo timeout: every byte "lost", the link alarm says so
])
def test_esp32_like_uart_rx_timeout(straight, tmp_path, rx_timeout_chars, echo_timeout_ms, works):
    fw = {"pilot": {"echo_timeout_ms": echo_timeout_ms}} if echo_timeout_ms else None
    r, res, summ = sail(straight, tmp_path / "rx", seed=6, scenario="current", duration_s=60,
                        fw_config=fw, overrides={"seatalk": {"rx_timeout_chars": rx_timeout_chars}})
    assert res["failure"] is None, res["failure"]
    ms = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    if works:
        assert ms[-1][1] == "AUTO", ms
        assert r.pilot.keys_accepted >= 5  # engaged and stepped through the slow echoes
        # the firmware writes its keys through; another talker (the pilot) retries on a collision
        # and gives a datagram up after 5: with a 1-char RX timeout that happened to 1-2 of the
        # pilot's datagrams per 60 s on 2 of 10 seeds (the fifth round's law) and 5 of 10 (the
        # sixth's): measured, docs/SEATALK.md; the link must still hold
        assert res["bus"]["gave_up"] <= 2, res["bus"]
        assert max(abs(x) for t, x, s, _, _ in res["truth_xte"] if t > 30) < 3.0
    else:
        assert r.pilot.keys_accepted == 0  # not even Auto got through
        assert ms[-1][1] == "ALARM", ms
        assert any(int(v) & AL_SEATALK for t, n, v in res["outputs"] if n == "alarms")


@pytest.mark.parametrize("seed", [1, 3, 4, 6])
def test_seatalk_noise_never_stalls_the_firmware(tmp_path, seed):
    """Seeds that once made the SeaTalk task spin on an already-due wait (no lockstep progress)."""
    track = benchtracks.straight(str(tmp_path / "s.csv"), 2.0)
    r, res, summ = sail(track, tmp_path / "n", seed=seed, faults=["st_noise@20:60"],
                        overrides={"sim": {"start_offset_m": 5.0},
                                   "water": {"current_mps": 0.2, "current_dir_deg": 90.0}},
                        duration_s=150)
    assert res["failure"] is None, res["failure"]
    assert summ["finished"], res["stop_reason"]


def test_buttons_through_the_firmware(straight, tmp_path):
    """HMI presses in the simulator: ENGAGE refused without RTK fixed (reason logged), STANDBY
    honoured at once, no engage by itself when RTK comes back."""
    from trackpilot_tools.logdecode import decode_files

    r, res, summ = sail(straight, tmp_path / "b", seed=2, duration_s=45,
                        overrides={"sim": {"engage_max_tries": 0}},  # only these presses
                        faults=["rtk_float@0:20", "button_engage@5", "button_engage@25", "button_standby@35"])
    ms = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    assert not any(v.startswith("AUTO") for t, v in ms if t < 20), ms
    d = decode_files(sorted((tmp_path / "b" / "fw" / "log").glob("*.tpl")))
    refused = [e for e in d.events if e.kind == "REFUSED"]
    assert any("RTK float" in e.text for e in refused), [e.text for e in refused]
    auto = [t for t, v in ms if v.startswith("AUTO")]
    assert auto and auto[0] >= 25.0, ms  # only the person's press after RTK came back engages
    after = [(t, v) for t, v in ms if t >= 35.0]
    assert after and after[0][1] == "STANDBY" and after[0][0] < 35.3, after
