"""Issue 14, the safety contract under races, odd settings and bad files: each hole reproduced
through the full firmware in the simulator (the issue's own commands), read back from the
firmware's log and the simulated pilot."""
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "host_tools"))
from trackpilot_tools.logdecode import decode_files  # noqa: E402
from trackpilot_tools.sim.runner import SimRun  # noqa: E402
from trackpilot_tools.sim.stcodec import MODE_AUTO, MODE_STANDBY  # noqa: E402

LOOP = ROOT / "tracks" / "middelburg_loop.csv"


def sail(out, **kw):
    r = SimRun(LOOP, out, **kw)
    res = r.run()
    assert res["failure"] is None, res["failure"]
    d = decode_files(sorted((Path(out) / "fw" / "log").glob("*.tpl")))
    return r, res, d


def modes(res):
    return [(t, v) for t, n, v in res["outputs"] if n == "mode"]


def pilot_log(res, t_from=0.0):
    return [(t, txt) for t, k, txt in res["events"] if k == "pilot" and t >= t_from]


def test_alarm_driver_never_recovers_by_itself(tmp_path):
    """14.1: in ALARM (GNSS gone beyond the hold time) a silent pilot used to get Standby (tiller
    free for 4.5 s) and Auto from the driver on its own. Nothing may be sent in ALARM.
    The issue's run had a 10 s GNSS hold (since then 40 s, dead reckoning): pinned here so that the
    pilot falls silent inside ALARM."""
    r, res, d = sail(tmp_path / "a", faults=["gnss_dropout@20:60", "pilot_silent@40:6"], duration_s=90,
                     fw_config={"modes": {"gnss_hold_s": 10}})
    ms = modes(res)
    alarm_t = [t for t, v in ms if v == "ALARM"]
    assert alarm_t and alarm_t[0] < 40, ms
    assert pilot_log(res, alarm_t[0]) == [], pilot_log(res, alarm_t[0])
    assert r.pilot.mode == MODE_AUTO  # kept its course
    texts = [e.text for e in d.events if e.kind == "PILOT"]
    assert not any("RECOVER" in t or "HANG" in t for t in texts), texts
    assert any("holding" in t for t in texts), texts


def test_our_auto_in_flight_never_undoes_a_persons_standby(tmp_path):
    """14.2: the person's Standby lands while our recovery's Auto is in flight; the pilot used to
    end in Auto. A person always wins: our Auto is answered with Standby, with an alarm.
    The person presses Standby as our recovery's Auto arrives at the pilot (the simulator watches
    for it), so the race is hit whatever the key sequence before it (float32 or 64-bit)."""
    r, res, d = sail(tmp_path / "r", faults=["pilot_hang_keys@20", "pilot_key_standby_on_auto@20"],
                     duration_s=40)
    t_press_s = r.pilot.standby_on_auto_us / 1e6
    texts = [e.text for e in d.events if e.kind == "PILOT"]
    # the race happened: our recovery's Auto was already sent, then the pilot acted on the
    # person's Standby and on our Auto after it
    assert any(t.startswith("RECOVER") and "auto sent" in t for t in texts), texts
    acted = [txt for t, txt in pilot_log(res, t_press_s) if txt.startswith("auto")]
    assert acted and acted[0].endswith("(sender 1)"), pilot_log(res, 20)
    assert r.pilot.mode == MODE_STANDBY, pilot_log(res, 20)
    assert any(t.startswith("OWN_AUTO_UNDONE") for t in texts), texts
    assert not any(v.startswith("AUTO") for t, v in modes(res) if t > t_press_s)


def test_sender_0_refused_and_the_persons_key_wins(tmp_path):
    """14.3: pilot.sender_id = 0 (the pilot's own keypad) made a person's +1 look like our echo.
    The firmware refuses such a file (defaults, alarm), and the person's key is a takeover."""
    with pytest.raises(ValueError, match="sender_id"):
        SimRun(LOOP, tmp_path / "x", fw_config={"pilot": {"sender_id": 0}})._fw_config()
    cfg = json.dumps({"pilot": {"sender_id": 0}}).encode()
    r, res, d = sail(tmp_path / "s", fw_config_bytes=cfg, faults=["button_ack@2", "pilot_key_plus1@30"],
                     duration_s=45)
    ms = modes(res)
    assert any(v.startswith("AUTO") for t, v in ms if t < 30), ms
    assert [v for t, v in ms if t >= 30][0] == "STANDBY", ms
    assert any(e.kind == "PILOT" and e.text.startswith("TAKEOVER") for e in d.events)
    assert r.pilot.keys_by_sender.get(0) is None  # the person's key was not sent by us


def test_rejected_config_alarm_and_engage_refused_until_ack(tmp_path):
    """14.4: one misspelled key used to run silently on defaults and ENGAGE was accepted."""
    cfg = json.dumps({"modes": {"xte_alarm": 5.0}}).encode()
    r, res, d = sail(tmp_path / "c", fw_config_bytes=cfg, faults=["button_ack@20"], duration_s=30)
    alarms = [e.text for e in d.events if e.kind == "ALARM"]
    assert any(t.startswith("config:") for t in alarms), alarms
    refused = [e for e in d.events if e.kind == "REFUSED"]
    assert refused and all("config" in e.text for e in refused), [e.text for e in refused]
    ms = modes(res)
    auto = [t for t, v in ms if v.startswith("AUTO")]
    assert auto and auto[0] > 20, ms  # only after the person's ACK
    assert any(e.kind == "ACK" and "config" in e.text for e in d.events)


def test_non_utf8_config_boots_on_defaults(tmp_path):
    """14.5: one Latin-1 byte in the config used to raise at every boot."""
    r, res, d = sail(tmp_path / "u", fw_config_bytes='{"boat": {"name": "Bär"}}'.encode("latin-1"),
                     duration_s=10)
    texts = [e.text for e in d.events if e.kind == "CONFIG"]
    assert any("UTF-8" in t for t in texts), texts
    assert any(e.kind == "ALARM" and e.text.startswith("config:") for e in d.events)


def test_estop_still_held_after_a_reset_refuses_engage(tmp_path):
    """14.14: the simulator did not resend the E-stop level after a reset, so ENGAGE at 90 s was
    accepted while the E-stop was held."""
    r, res, d = sail(tmp_path / "e", faults=["estop@80:30", "reset@85", "button_engage@90"],
                     overrides={"sim": {"engage_max_tries": 1}}, duration_s=100)
    ms = modes(res)
    assert not any(v.startswith("AUTO") for t, v in ms if t >= 80), ms
    assert [v for t, v in ms if t >= 85][-1] == "ESTOP", ms
    refused = [e.text for e in d.events if e.kind == "REFUSED"]
    assert any("E-stop" in t for t in refused), refused


def test_hand_remote_with_our_sender_id_repeating_our_key_is_a_takeover(tmp_path):
    """14.3: the old echo test took any same key from our sender id within echo_window_ms (1 s)
    for our own echo; a hand remote (Z101) with our sender id pressing it was not a person."""
    r, res, d = sail(tmp_path / "z", scenario="current", faults=["remote_key_echo@30"], duration_s=60)
    fault = [t for t, k, txt in res["events"] if k == "fault" and "hand remote repeats" in txt]
    assert fault, res["events"]
    ms = modes(res)
    after = [v for t, v in ms if t >= fault[0]]
    assert after and after[0] == "STANDBY", ms
    tk = [e.text for e in d.events if e.kind == "PILOT" and e.text.startswith("TAKEOVER")]
    assert tk and "sender 1" in tk[0], tk


pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)
