"""`trackpilot bench`, the fault matrix (issue 5): every fault of the simulator's list
(sim/scenarios.FAULTS) injected once during a track, the firmware's reaction read from its own log
(logdecode: control records and events) and checked against the reaction defined for it
(docs/MODES.md, issue 4). Reported: whether the defined reaction happened, time to detect, time to
recover, max truth |xte| during the fault, whether the track completed.

The track: a 20 m U-turn with 200 m legs at 1.5 m/s, `current` scenario (0.2 m/s), law `los`; the
fault starts 40 s into the run (about 35 s after engaging, on the first leg). A person takes part
as on the boat: `reengage_s` after the firmware left AUTO they press ENGAGE again (only from
STANDBY, as the runner's person does), and if the firmware sits in ALARM (or ESTOP) 5 s after the
fault ended they press STANDBY (or ACK once the E-stop input is released). Times are simulated
seconds; "detect" is from the fault's start, "recover" from its end (for instantaneous faults:
from its start) to the first record in AUTO with the guidance running and no alarm from the fault.

Besides the single faults, combined cases (CASES, issue 14) that once broke the safety contract:
the takeover race (a person's Standby while our recovery's Auto is in flight; the issue's own run
on tracks/middelburg_loop.csv, deterministic), sender id 0 in the config file, a config file with
a misspelled key, and a silent pilot while the firmware is in ALARM (no recovery by the driver).
"""
import math
from pathlib import Path

from .sim import scenarios

T_FAULT = 40.0
REENGAGE_S = 5.0
TICK_BASE = (1 << 30) - 60000  # sim_main's default --tick-base
TICKS_MASK = (1 << 30) - 1

# alarm bits (trackpilot.core.modes)
AL = {"takeover": 1, "gnss": 2, "gnss_timeout": 4, "pilot_hang": 8, "pilot_lost": 16, "motor_link": 32,
      "xte": 64, "arrival": 128, "estop": 256, "seatalk": 1024}
STANDBY, AUTO, ALARM, ESTOP = 0, 1, 2, 3

# name: (duration s or None, the defined reaction (text), kind of check)
SPEC = {
    "rtk_float": (20.0, "keeps steering on RTK float (modes.steer_min_rtk = float): stays AUTO, guidance on, "
                        "no GNSS alarm", "keep"),
    "rtk_single": (20.0, "AUTO(dead-reckoning) + gnss alarm at once: steers on the dead-reckoned position "
                         "(the receiver's velocity, compass heading) at slow RPM; single seconds count 1/4 of "
                         "modes.gnss_hold_s (40 s), so guidance resumes by itself when RTK is back",
                   "degraded"),
    "heading_loss": (6.0, "AUTO(dead-reckoning) + gnss alarm: the RTK position with the compass heading; "
                          "guidance resumes when the heading is back (within gnss_hold_s)", "degraded"),
    "gnss_dropout": (6.0, "AUTO(dead-reckoning) within 0.5 s (gap timer), slow RPM, steered on the "
                          "dead-reckoned position; guidance resumes on RTK float/fixed within gnss_hold_s, "
                          "else ALARM + gnss_timeout", "degraded"),
    "compass_bend": (20.0, "the pilot's compass bent 6 deg: the learnt compass offset and the GNSS heading "
                           "keep the guidance on: stays AUTO, guidance on, no alarm", "keep"),
    "pilot_hang_steer": (None, "hang detected (pilot_hang alarm, AUTO(recovering)), Standby then Auto clears "
                               "it, guidance resumes", "hang"),
    "pilot_hang_keys": (None, "hang detected (pilot_hang alarm, AUTO(recovering)), Standby then Auto clears "
                              "it, guidance resumes", "hang"),
    "pilot_silent": (20.0, "pilot not answering (status timeout 3.5 s): pilot_hang/pilot_lost alarm; "
                           "recovery or ALARM", "pilot_alarm"),
    "pilot_key_standby": (None, "takeover: STANDBY + takeover alarm, the firmware stops keying the pilot",
                          "takeover"),
    "pilot_key_auto": (None, "takeover: STANDBY + takeover alarm, the firmware stops keying the pilot",
                       "takeover"),
    "pilot_key_minus10": (None, "takeover: STANDBY + takeover alarm, the firmware stops keying the pilot",
                          "takeover"),
    "pilot_key_plus10": (None, "takeover: STANDBY + takeover alarm, the firmware stops keying the pilot",
                         "takeover"),
    "pilot_key_minus1": (None, "takeover: STANDBY + takeover alarm, the firmware stops keying the pilot",
                         "takeover"),
    "pilot_key_plus1": (None, "takeover: STANDBY + takeover alarm, the firmware stops keying the pilot",
                        "takeover"),
    "st_noise": (40.0, "no reaction needed: keeps steering in AUTO (retries), no false takeover, no ALARM",
                 "keep"),
    "st_tx_lost": (20.0, "lost echo detected: seatalk alarm, then ALARM (cannot send keys)", "seatalk_alarm"),
    "st_rx_lost": (20.0, "hears nothing: no status and no echo -> pilot or seatalk alarm", "pilot_alarm"),
    "st_other_talker": (40.0, "collisions resolved by back-off and retry: keeps steering in AUTO, no false "
                              "takeover, no ALARM", "keep"),
    "motor_link_loss": (20.0, "ALARM + motor_link (the pilot keeps its course, slow RPM)", "alarm_motor"),
    "estop": (10.0, "ESTOP latched at once, pilot Standby, 0 RPM; cleared by ACK after release -> STANDBY",
              "estop"),
    "reset": (None, "restarts in STANDBY, the leg restored from state.json, never engages by itself "
                    "(only the person's ENGAGE brings AUTO back)", "reset"),
    "button_standby": (None, "STANDBY at once, Standby key to the pilot", "standby"),
    "button_engage": (None, "already in AUTO: stays in AUTO (re-engage is harmless)", "keep"),
    "remote_key_echo": (None, "takeover: a hand remote with our sender id repeating our key is a person: "
                              "STANDBY + takeover alarm, the firmware stops keying the pilot", "takeover"),
    "button_ack": (None, "nothing sounding in AUTO: stays in AUTO (ACK only mutes)", "keep"),
    "button_trial": (None, "in AUTO: refused (a commissioning trial starts only from STANDBY), stays in AUTO",
                     "keep"),
}


_LOOP = Path(__file__).resolve().parents[2] / "tracks" / "middelburg_loop.csv"

# name: faults (absolute times, s), the firmware's config file (bytes) or None, the track (None: the
# matrix's U-turn), the scenario, the defined reaction, end_s for the person's ALARM check
CASES = {
    "race_takeover_vs_recovery": {
        # the person presses Standby as our recovery's Auto reaches the pilot (the simulator watches
        # for it): the race is hit whatever the key sequence before it, on any interpreter
        "faults": ["pilot_hang_keys@20", "pilot_key_standby_on_auto@20"], "config": None, "track": _LOOP,
        "scenario": "calm", "end_s": 31.2,
        "expected": "the person's Standby wins over our recovery's Auto already in flight: pilot ends in "
                    "Standby (our Auto answered with Standby), STANDBY + takeover alarm, no AUTO by itself"},
    "sender0_config": {
        "faults": ["button_ack@2", "pilot_key_plus1@%g" % T_FAULT], "config": b'{"pilot": {"sender_id": 0}}',
        "track": None, "scenario": "current", "end_s": T_FAULT,
        "expected": "sender id 0 refused (config alarm, defaults; ENGAGE after ACK); the person's +1 on the "
                    "pilot is a takeover: STANDBY + takeover alarm, no more keys"},
    "bad_config": {
        "faults": ["button_ack@%g" % T_FAULT, "button_engage@%g" % (T_FAULT + 1)],
        "config": b'{"modes": {"xte_alarm": 5.0}}', "track": None, "scenario": "current", "end_s": T_FAULT,
        "expected": "misspelled key: config alarm at boot, every ENGAGE refused until a person's ACK, then "
                    "AUTO on the defaults"},
    "alarm_no_recovery": {
        # a 10 s GNSS hold (the default is 40 s of dead reckoning) so the pilot falls silent in ALARM
        "faults": ["gnss_dropout@%g:60" % (T_FAULT - 20), "pilot_silent@%g:6" % T_FAULT],
        "config": b'{"modes": {"gnss_hold_s": 10}}',
        "track": None, "scenario": "current", "end_s": T_FAULT + 40,
        "expected": "in ALARM (GNSS gone beyond the hold time) a silent pilot is not recovered: no keys, "
                    "the pilot stays in Auto on its course"},
}


# simulator faults that only mean something inside a case (alone in AUTO nothing triggers them)
CASE_ONLY = {"pilot_key_standby_on_auto": "race_takeover_vs_recovery"}


def fault_list():
    missing = sorted(set(scenarios.FAULTS) - set(SPEC) - set(CASE_ONLY))
    return [f for f in scenarios.FAULTS if f not in CASE_ONLY] + list(CASES), missing


def expected_text(name):
    return CASES[name]["expected"] if name in CASES else SPEC[name][1]


def _person(r, end_s):
    """A person on board: 5 s after the fault ended, if the firmware sits in ALARM they press STANDBY,
    in ESTOP (input released) they press ACK; the runner's reengage_s then engages again."""

    def act(t_us):
        t_ms = t_us // 1000
        mode = r.mode or ""
        if mode.startswith("ALARM"):
            r.send_input(t_ms, "button=STANDBY")
        elif mode.startswith("ESTOP"):
            r.send_input(t_ms, "button=ACK")
        if t_ms < (end_s + 60.0) * 1000:
            r.sched.at(t_us + 5_000_000, act)

    r.sched.at(int((end_s + 5.0) * 1e6), act)


def _records(out, res):
    """Firmware log records with sim time (t_sim): controls, events."""
    from .logdecode import decode_files, session_key

    files = sorted(Path(out, "fw", "log").glob("*.tpl"), key=session_key)
    if not files:
        return [], []
    d = decode_files([str(f) for f in files])
    sessions = sorted({session_key(f)[1] for f in files})
    t0 = [0.0] + [t for t, k, _ in sorted(res["events"]) if k == "reset"]
    for rec in d.controls + d.events:
        s = sessions.index(session_key(rec.file)[1])
        rec.t_sim = t0[min(s, len(t0) - 1)] + ((rec.t_ms - TICK_BASE) & TICKS_MASK) / 1000.0
    return d.controls, d.events


def run_fault(job):
    from .sim.runner import SimRun

    name, track, out = job["fault"], job["track"], job["out"]
    if name in CASES:
        return run_case(job)
    dur, _, _ = SPEC[name]
    text = "%s@%g" % (name, T_FAULT) + (":%g" % dur if dur else "")
    r = SimRun(track, out, seed=job.get("seed", 1), law="los", scenario="current", faults=[text],
               reengage_s=REENGAGE_S)
    end_s = T_FAULT + (dur or 0.0)
    _person(r, end_s)
    row, fired = _sail(r, out, job, lambda ctl, evs, res: evaluate(name, dur, ctl, evs, res, r), text)
    if fired:
        row["note"] = "firmware stopped answering, run killed: %s; %s" % (fired, row["note"])
    return row


def _sail(r, out, job, judge, fault):
    """Run r under the wall-clock watchdog, decode its log, judge it: (row, what the dog killed)."""
    from .bench_perf import watchdog

    dog = watchdog(r, job.get("timeout", 300))
    res = r.run()
    dog.cancel()
    try:
        ctl, evs = _records(out, res)
    except Exception as e:  # a log the decoder cannot read is a finding too
        ctl, evs = [], []
        res.setdefault("decode_error", str(e))
    row = judge(ctl, evs, res)
    row.update({"fault": fault, "finished": res["finished_s"] is not None, "stop": res["stop_reason"],
                "failure": res["failure"], "timed_out": dog.fired})
    return row, dog.fired


def run_case(job):
    from .sim.runner import SimRun

    name, out = job["fault"], job["out"]
    c = CASES[name]
    r = SimRun(c["track"] or job["track"], out, seed=job.get("seed", 1), law="los", scenario=c["scenario"],
               faults=c["faults"], reengage_s=0.0 if name == "race_takeover_vs_recovery" else REENGAGE_S,
               fw_config_bytes=c["config"], duration_s=job.get("duration_s", T_FAULT + 60.0))
    _person(r, c["end_s"])
    return _sail(r, out, job, lambda ctl, evs, res: evaluate_case(name, ctl, evs, res, r), name)[0]


def evaluate_case(name, ctl, evs, res, r):
    from .sim.stcodec import MODE_STANDBY

    case = CASES[name]
    modes = [(t, v) for t, n, v in res["outputs"] if n == "mode"]
    ok, detect, note = False, None, ""
    F = T_FAULT
    if name == "race_takeover_vs_recovery":
        if r.pilot.standby_on_auto_us is None:  # our recovery's Auto never came
            return {"name": name, "expected": case["expected"], "reaction_ok": False,
                    "detect_s": None, "recover_s": None, "max_xte_m": None,
                    "note": "no recovery Auto: the race never happened", "modes": [v for t, v in modes][:8]}
        F = r.pilot.standby_on_auto_us / 1e6  # the person's Standby
        detect = _first(ctl, lambda c: c.mode != AUTO, F - 0.5)
        undone = any(e.kind == "PILOT" and e.text.startswith("OWN_AUTO_UNDONE") for e in evs)
        auto_after = [t for t, v in modes if t > F and v.startswith("AUTO")]
        ok = r.pilot.mode == MODE_STANDBY and undone and not auto_after and detect is not None
        note = ("our Auto landed after the person's Standby and was answered with Standby" if ok else
                "pilot mode %s at the end, our Auto answered: %s" % (r.pilot.mode, undone))
    elif name == "sender0_config":
        cfg_al = any(e.kind == "ALARM" and e.text.startswith("config:") for e in evs)
        detect = _first(ctl, lambda c: c.mode != AUTO, F)
        tk = _first(ctl, lambda c: c.alarms & AL["takeover"], F)
        ks = [c.keys_sent for c in ctl if detect is not None and detect + 1.0 <= c.t_sim < F + 5.0]
        ok = cfg_al and tk is not None and detect is not None and detect - F <= 2.0 and (not ks or ks[-1] == ks[0])
        note = "" if ok else "config alarm %s, takeover alarm at %s" % (cfg_al, tk)
    elif name == "bad_config":
        cfg_al = any(e.kind == "ALARM" and e.text.startswith("config:") for e in evs)
        refused = [e for e in evs if e.kind == "REFUSED" and e.t_sim < F]
        early = [t for t, v in modes if t < F and v.startswith("AUTO")]
        detect = _first(ctl, lambda c: c.mode == AUTO, F)
        ok = cfg_al and bool(refused) and not early and detect is not None
        note = "%d ENGAGE refused before the ACK" % len(refused)
    elif name == "alarm_no_recovery":
        F = T_FAULT - 20  # times from the dropout
        alarm_t = _first(ctl, lambda c: c.mode == ALARM, F)
        in_alarm = [c for c in ctl if alarm_t is not None and c.t_sim >= alarm_t and c.mode == ALARM]
        pilot_got = [txt for t, k, txt in res["events"]
                     if k == "pilot" and alarm_t is not None and alarm_t <= t <= T_FAULT + 20 and "sender 1" in txt]
        recov = [e.text for e in evs if e.kind == "PILOT" and ("RECOVER" in e.text or "HANG" in e.text)]
        detect = alarm_t
        ok = bool(in_alarm) and not pilot_got and not recov and in_alarm[-1].keys_sent == in_alarm[0].keys_sent
        note = "" if ok else "pilot got %s; driver %s" % (pilot_got[:2], recov[:2])
    xs = [abs(float(row[24])) for row in r.truth_rows if float(row[0]) >= F]
    return {"name": name, "expected": case["expected"], "reaction_ok": bool(ok),
            "detect_s": None if detect is None else round(detect - F, 2), "recover_s": None,
            "max_xte_m": round(max(xs), 2) if xs else None, "note": note,
            "modes": [v for t, v in modes if t >= F][:8]}


def _first(recs, pred, t_from, t_to=1e9):
    for c in recs:
        if t_from <= c.t_sim <= t_to and pred(c):
            return c.t_sim
    return None


def evaluate(name, dur, ctl, evs, res, r):
    _, expected, kind = SPEC[name]
    F = T_FAULT
    if name == "remote_key_echo":
        # armed at T_FAULT, the hand remote repeats the firmware's next keystroke: the person acts
        # then (seconds later on a settled straight), and the reaction is timed from it
        acted = [t for t, k, txt in res["events"] if k == "fault" and "hand remote repeats" in txt]
        if acted:
            F = acted[0]
    E = F + (dur or 0.0)
    after = [c for c in ctl if c.t_sim >= F]
    detect = None
    ok = False
    note = ""
    fault_bits = 0

    def guided_ok(bits):
        return lambda c: c.mode == AUTO and c.guided and not (c.alarms & bits)

    if kind == "keep":
        w = E + 2.0 if dur else F + 10.0  # the window in which it must stay in guided AUTO
        bad = [c for c in after if c.t_sim <= w and (c.mode != AUTO or not c.guided)]
        ok = not bad and any(c.t_sim <= w for c in after)
        if name == "rtk_float":
            detect = _first(after, lambda c: c.rtk == 2, F)  # fix.RTK_FLOAT
            note = "firmware saw RTK float" if detect is not None else "firmware never saw float"
        if bad:
            b = bad[0]
            note = "left guided AUTO at %.1f s: mode %d, alarms %s" % (b.t_sim, b.mode, _alarm_names(b.alarms))
            detect = b.t_sim
        fault_bits = AL["gnss"] | AL["takeover"]
    elif kind in ("degraded", "gnss_timeout"):
        fault_bits = AL["gnss"] | AL["gnss_timeout"]
        detect = _first(after, lambda c: c.alarms & AL["gnss"], F)
        # no control record is written while no epoch arrives (dropout): the mode event counts too
        ev = _first(evs, lambda e: (e.kind == "MODE" and ("degraded" in e.text or "dead-reckoning" in e.text))
                    or (e.kind == "ALARM" and "gnss" in e.text.lower()), F)
        if ev is not None and (detect is None or ev < detect):
            detect = ev
        # guided on an untrusted GNSS fix (dead-reckoned steps are logged with rtk 0, "none")
        blind = [c for c in after if detect is not None and detect <= c.t_sim <= E and c.guided
                 and c.rtk != 0]
        if kind == "gnss_timeout":
            to = _first(after, lambda c: c.alarms & AL["gnss_timeout"] or c.mode == ALARM, F)
            ok = detect is not None and detect - F <= 1.5 and to is not None and abs(to - F - 40.0) <= 2.0
            note = "ALARM/gnss_timeout at +%.1f s" % (to - F) if to is not None else "no gnss_timeout"
        else:
            ok = detect is not None and detect - F <= 1.5 and not blind
            if blind:
                note = "guidance ran while GNSS was bad"
            to = _first(after, lambda c: c.alarms & AL["gnss_timeout"], F)
            if to is not None:
                note = (note + "; " if note else "") + "ALARM/gnss_timeout at +%.1f s" % (to - F)
    elif kind == "hang":
        fault_bits = AL["pilot_hang"] | AL["pilot_lost"]
        detect = _first(after, lambda c: c.alarms & AL["pilot_hang"], F)
        ok = detect is not None
        if detect is None:
            lost = _first(after, lambda c: c.alarms & AL["pilot_lost"] or c.mode == ALARM, F)
            note = "no pilot_hang alarm" + (" (ALARM at +%.1f s)" % (lost - F) if lost else "")
    elif kind == "pilot_alarm":
        fault_bits = AL["pilot_hang"] | AL["pilot_lost"] | AL["seatalk"]
        detect = _first(after, lambda c: c.alarms & fault_bits or c.mode == ALARM, F)
        ok = detect is not None and detect - F <= 6.0
    elif kind == "seatalk_alarm":
        fault_bits = AL["seatalk"] | AL["pilot_lost"] | AL["pilot_hang"]
        detect = _first(after, lambda c: c.alarms & fault_bits or c.mode == ALARM, F)
        ok = detect is not None and detect <= E
        if detect is None:
            note = "no alarm while the firmware's bytes were lost"
    elif kind == "alarm_motor":
        fault_bits = AL["motor_link"]
        detect = _first(after, lambda c: c.alarms & AL["motor_link"], F)
        al = _first(after, lambda c: c.mode == ALARM, F)
        ok = detect is not None and al is not None
    elif kind == "estop":
        fault_bits = AL["estop"]
        detect = _first(after, lambda c: c.mode == ESTOP, F)
        zero = _first(after, lambda c: c.mode == ESTOP and c.rpm_set == 0, F)
        ok = detect is not None and detect - F <= 1.0 and zero is not None
    elif kind == "takeover":
        fault_bits = AL["takeover"]
        detect = _first(after, lambda c: c.mode != AUTO, F)
        tk = _first(after, lambda c: c.alarms & AL["takeover"], F)
        ok = detect is not None and detect - F <= 2.0 and tk is not None
        if ok:  # no keys sent between the takeover and the person's ENGAGE
            eng = [t for t, k, txt in res["events"] if k == "input" and "ENGAGE" in txt and t > F]
            t_eng = min(eng) if eng else 1e9
            ks = [c.keys_sent for c in after if detect + 1.0 <= c.t_sim < t_eng]
            if ks and ks[-1] != ks[0]:
                ok = False
                note = "kept keying the pilot after the takeover"
        if tk is None and detect is not None:
            note = "left AUTO without a takeover alarm"
    elif kind == "standby":
        detect = _first(after, lambda c: c.mode == STANDBY, F)
        ok = detect is not None and detect - F <= 1.0
    elif kind == "reset":
        modes = [(t, v) for t, n, v in res["outputs"] if n == "mode" and t >= F]
        eng = [t for t, k, txt in res["events"] if k == "input" and "ENGAGE" in txt and t > F]
        first_auto = next((t for t, v in modes if v.startswith("AUTO")), None)
        restored = any(e.kind == "STATE" and "restored" in e.text for e in evs)
        ok = (bool(modes) and modes[0][1].startswith("STANDBY") and restored
              and (first_auto is None or (eng and min(eng) <= first_auto)))
        detect = modes[0][0] if modes else None
        note = "leg restored" if restored else "leg not restored"
    # recovery: back in guided AUTO without the fault's alarms, after the fault's end
    t_rec_from = E if dur else F
    rec = _first(ctl, guided_ok(fault_bits), max(t_rec_from, detect or t_rec_from) if kind != "keep" else t_rec_from)
    if kind == "keep":
        rec = E if ok else rec
        if name == "rtk_float":
            rec = _first(ctl, lambda c: c.rtk == 3, E)  # fix.RTK_FIXED again
    recover = None if rec is None else rec - t_rec_from
    # max truth |xte| from the fault's start to the recovery (or 30 s after its end)
    t_hi = rec if rec is not None else E + 30.0
    xs = [abs(float(row[24])) for row in r.truth_rows if F <= float(row[0]) <= max(t_hi, E)]
    return {"name": name, "expected": expected, "reaction_ok": bool(ok),
            "detect_s": None if detect is None else round(detect - F, 2),
            "recover_s": None if recover is None else round(recover, 2),
            "max_xte_m": round(max(xs), 2) if xs else None, "note": note,
            "modes": [v for t, n, v in res["outputs"] if n == "mode" and t >= F][:8]}


def _alarm_names(bits):
    return ",".join(k for k, b in AL.items() if bits & b) or "none"
