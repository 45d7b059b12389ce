# Mode machine: the safety table of ARCHITECTURE.md, under the MicroPython unix port.
from tpassert import eq, true
from trackpilot import modes as M


def _auto(mm, t=0):
    ok, why = mm.engage(t, None, "test")
    true(ok, why)
    return mm


def test_boot_is_standby_and_leaves_pilot():
    mm = M.ModeMachine()
    eq(mm.mode, M.STANDBY)
    eq(mm.pilot, M.PILOT_LEAVE)  # never send Auto, leave the pilot as found
    eq(mm.alarms, 0)


def test_engage_refused_with_reason_and_logged():
    mm = M.ModeMachine()
    ok, why = mm.engage(0, "no RTK fixed fix (float)", "HMI")
    true(not ok)
    eq(mm.mode, M.STANDBY)
    ev = mm.drain_events()
    eq(ev[0][0], "REFUSED")
    true("float" in ev[0][1])


def test_engage_and_standby_log_mode_changes():
    mm = _auto(M.ModeMachine())
    eq(mm.mode, M.AUTO)
    eq(mm.pilot, M.PILOT_STEER)
    eq(mm.motor, M.MOTOR_TRACK)
    mm.standby(10, "remote")
    eq(mm.mode, M.STANDBY)
    eq(mm.pilot, M.PILOT_STANDBY)
    kinds = [k for k, _ in mm.drain_events()]
    eq(kinds.count("MODE"), 2)


def test_takeover_wins_and_never_reengages():
    mm = _auto(M.ModeMachine())
    mm.takeover(100, "key -10 from sender 0")
    eq(mm.mode, M.STANDBY)
    eq(mm.pilot, M.PILOT_LEAVE)
    eq(mm.motor, M.MOTOR_HOLD_CAPPED)
    true(mm.alarms & M.AL_TAKEOVER)
    # good GNSS and time passing never bring AUTO back
    for t in range(0, 60000, 200):
        mm.gnss_quality(t, True)
    eq(mm.mode, M.STANDBY)


def test_gnss_hold_then_alarm():
    mm = M.ModeMachine({"gnss_hold_s": 10})
    _auto(mm)
    mm.gnss_quality(1000, False, "GNSS stale")
    eq(mm.mode, M.AUTO)
    true(mm.degraded)
    eq(mm.pilot, M.PILOT_HOLD)
    eq(mm.motor, M.MOTOR_SLOW)
    mm.gnss_quality(10999, False, "GNSS stale")
    eq(mm.mode, M.AUTO)
    mm.gnss_quality(11001, False, "GNSS stale")
    eq(mm.mode, M.ALARM)
    true(mm.alarms & M.AL_GNSS_TIMEOUT)
    # GNSS back: stays in ALARM until a person acts
    mm.gnss_quality(12000, True)
    eq(mm.mode, M.ALARM)


def test_gnss_short_dropout_resumes():
    mm = _auto(M.ModeMachine({"gnss_hold_s": 10}))
    mm.gnss_quality(1000, False, "RTK float")
    mm.gnss_quality(5000, True)
    eq(mm.mode, M.AUTO)
    true(not mm.degraded)
    eq(mm.pilot, M.PILOT_STEER)


def test_hold_time_across_tick_wrap():
    mm = _auto(M.ModeMachine({"gnss_hold_s": 10}))
    t0 = (1 << 30) - 3000
    mm.gnss_quality(t0, False, "stale")
    mm.gnss_quality(5000, False, "stale")  # 8 s later, after the wrap
    eq(mm.mode, M.AUTO)
    mm.gnss_quality(7500, False, "stale")  # 10.5 s later
    eq(mm.mode, M.ALARM)


def test_estop_latches_until_cleared_by_person():
    mm = _auto(M.ModeMachine())
    mm.estop(0, True)
    eq(mm.mode, M.ESTOP)
    eq(mm.motor, M.MOTOR_ZERO)
    eq(mm.pilot, M.PILOT_STANDBY)
    ok, _ = mm.engage(10, None)
    true(not ok)
    ok, _ = mm.estop_clear(20, input_active=True)
    true(not ok)
    eq(mm.mode, M.ESTOP)
    ok, _ = mm.estop_clear(30, input_active=False)
    true(ok)
    eq(mm.mode, M.STANDBY)


def test_pilot_hang_recover_and_unrecoverable():
    mm = _auto(M.ModeMachine())
    mm.pilot_hang(0, "compass not converging")
    eq(mm.mode, M.AUTO)
    true(mm.recovering)
    eq(mm.motor, M.MOTOR_SLOW)
    mm.pilot_recovered(100)
    true(not mm.recovering)
    eq(mm.pilot, M.PILOT_STEER)
    mm.pilot_hang(200, "ignores keys")
    mm.pilot_lost(300, "3 recoveries failed")
    eq(mm.mode, M.ALARM)


def test_motor_link_loss_alarm():
    mm = _auto(M.ModeMachine())
    mm.motor_link(0, False, "no reply 1.5 s")
    eq(mm.mode, M.ALARM)
    true(mm.alarms & M.AL_MOTOR_LINK)


def test_arrival_standby_or_hold():
    mm = _auto(M.ModeMachine())
    mm.arrived(0, "last waypoint")
    eq(mm.mode, M.STANDBY)
    true(mm.alarms & M.AL_ARRIVAL)
    mm2 = _auto(M.ModeMachine({"on_arrival": "hold"}))
    mm2.arrived(0, "last waypoint")
    eq(mm2.mode, M.AUTO)
    true(mm2.holding)
    eq(mm2.pilot, M.PILOT_HOLD)


def test_xte_alarm_and_ack():
    mm = _auto(M.ModeMachine({"xte_alarm_m": 5.0}))
    mm.xte(0, 6.0)
    true(mm.alarms & M.AL_XTE)
    true(mm.sounding() & M.AL_XTE)
    mm.ack(1)
    true(not mm.sounding() & M.AL_XTE)
    true(mm.alarms & M.AL_XTE)
    mm.xte(2, -1.0)
    true(not mm.alarms & M.AL_XTE)


def test_standby_from_every_mode():
    for setup in ("standby", "auto", "alarm"):
        mm = M.ModeMachine()
        if setup != "standby":
            _auto(mm)
        if setup == "alarm":
            mm.motor_link(0, False, "x")
        mm.standby(5)
        eq(mm.mode, M.STANDBY, setup)


def test_seatalk_lost_alarm_hold_and_no_reengage():
    mm = _auto(M.ModeMachine())
    mm.drain_events()
    mm.set_alarm(M.AL_SEATALK, True, "2 datagrams in a row not sent")
    eq(mm.mode, M.AUTO)  # alarm only
    mm.seatalk_lost(1000, "3 datagrams in a row not sent")
    eq(mm.mode, M.ALARM)
    eq(mm.pilot, M.PILOT_HOLD)  # the pilot keeps its last course in Auto
    eq(mm.motor, M.MOTOR_SLOW)
    true(mm.alarms & M.AL_SEATALK)
    ev = mm.drain_events()
    true(any(k == "MODE" and "SeaTalk cannot send" in t for k, t in ev), ev)
    mm.set_alarm(M.AL_SEATALK, False, "sent again")
    eq(mm.alarms & M.AL_SEATALK, 0)
    eq(mm.mode, M.ALARM)  # never back to AUTO by itself
    # in STANDBY: alarm, no mode change
    mm2 = M.ModeMachine()
    mm2.seatalk_lost(0, "x")
    eq(mm2.mode, M.STANDBY)
    true(mm2.alarms & M.AL_SEATALK)


def test_dead_reckoning_continues_the_same_auto():
    # issue 12: a gap inside AUTO steers on the dead-reckoned position at slow RPM, resumes by
    # itself on a good fix (no engagement logged), ALARM only past the hold time
    mm = _auto(M.ModeMachine({"gnss_hold_s": 40}))
    mm.drain_events()
    mm.gnss_quality(1000, False, "no GNSS epoch for 280 ms", dr=True, bad_s=0.3)
    eq(mm.mode, M.AUTO)
    true(mm.degraded and mm.dead_reckoning)
    eq(mm.pilot, M.PILOT_STEER)
    eq(mm.motor, M.MOTOR_SLOW)
    eq(mm.state_text(), "AUTO(dead-reckoning)")
    mm.gnss_quality(16000, False, "RTK single", dr=True, bad_s=15.0)
    mm.gnss_quality(21000, True)
    eq(mm.mode, M.AUTO)
    true(not mm.degraded and not mm.dead_reckoning)
    eq(mm.pilot, M.PILOT_STEER)
    eq(mm.motor, M.MOTOR_TRACK)
    texts = [t for _, t in mm.drain_events()]
    true(not any("engaged" in x for x in texts), repr(texts))
    true(any("guidance resumed" in x for x in texts), repr(texts))


def test_dead_reckoning_hold_counts_the_weighted_gap():
    mm = _auto(M.ModeMachine({"gnss_hold_s": 40}))
    mm.gnss_quality(0, False, "stale", dr=True, bad_s=0.3)
    mm.gnss_quality(45000, False, "RTK single", dr=True, bad_s=39.0)  # 45 s, Doppler part weighed
    eq(mm.mode, M.AUTO)
    mm.gnss_quality(46000, False, "stale", dr=True, bad_s=40.2)
    eq(mm.mode, M.ALARM)
    eq(mm.pilot, M.PILOT_HOLD)
    true(mm.alarms & M.AL_GNSS_TIMEOUT)
    mm.gnss_quality(47000, True)
    eq(mm.mode, M.ALARM)  # only a person engages again


def test_no_dead_reckoning_holds_course():
    mm = _auto(M.ModeMachine({"gnss_hold_s": 40}))
    mm.gnss_quality(0, False, "stale", dr=False)
    eq(mm.pilot, M.PILOT_HOLD)
    eq(mm.state_text(), "AUTO(degraded)")
    mm.gnss_quality(200, False, "stale", dr=True, bad_s=0.2)  # compass offset became known
    eq(mm.pilot, M.PILOT_STEER)
    true(mm.dead_reckoning)
