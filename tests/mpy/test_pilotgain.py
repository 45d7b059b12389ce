# nav/pilotgain.py under MicroPython, and the los law's use of it: the pilot's rudder gain learnt
# from its reports in closed loop, and the clip the law sets from it (docs/NAVIGATION.md "Twelfth
# round").
import tpassert as t
from trackpilot.compat import ticks_add
from trackpilot.nav.guidance import LosLaw
from trackpilot.nav.pilotgain import PilotGain

_DT_S = 0.05  # the synthetic pilot's and boat's step
_REPORT_S = 0.25  # a status every quarter second, as the ST2000+ sends 0x84


def _sail(gain, damping_s, ram_dps=10.0, deadband_deg=1.0, seconds=150.0, steps=(10, -10, 20, -20, 15, -15),
          every_s=12.0, t0_ms=0, est=None, law=None):
    """A pilot (P-D on its lagging compass, a deadband, a rate-limited ram with a 1-deg deadband)
    on a Nomoto boat, its locked course stepped every every_s; each status (whole degrees) goes to
    the estimate (or the law). Returns the estimate and the notes the law gave."""
    est = est if est is not None else PilotGain()
    heading = compass = rudder = yaw_dps = 0.0
    course = 0.0
    rate_f = 0.0
    notes = []
    n_steps = int(seconds / _DT_S)
    per_report = int(_REPORT_S / _DT_S)
    per_step = int(every_s / _DT_S)
    for i in range(n_steps):
        if i and i % per_step == 0:
            course += steps[(i // per_step - 1) % len(steps)]
        # the boat: yaw rate follows the rudder (K 0.4 deg/s per deg, T 1.5 s), some wave yaw
        yaw_dps += (0.4 * rudder - yaw_dps) * _DT_S / 1.5
        heading += yaw_dps * _DT_S
        old = compass
        compass += (heading - compass) * _DT_S / 0.5  # the fluxgate lags 0.5 s
        rate_f += ((compass - old) / _DT_S - rate_f) * _DT_S / 0.5
        e = course - compass
        ee = 0.0 if abs(e) <= deadband_deg else e - (deadband_deg if e > 0 else -deadband_deg)
        cmd = max(-30.0, min(30.0, gain * ee - damping_s * rate_f))
        if abs(cmd - rudder) > 1.0:
            mv = ram_dps * _DT_S
            rudder += max(-mv, min(mv, cmd - rudder))
        if i % per_report == 0:
            t_ms = ticks_add(t0_ms, int(i * _DT_S * 1000))
            c_int = float(int(compass + 360.5) - 360) % 360.0
            r_int = float(int(rudder + 30.5) - 30)
            if law is not None:
                note = law.pilot_status(t_ms, c_int, course % 360.0, r_int, deadband_deg)
                if note:
                    notes.append(note)
            else:
                est.step(t_ms, c_int, course % 360.0, r_int, deadband_deg, ram_dps, 30.0)
    return (law.gain if law is not None else est), notes


def test_the_gain_is_found_within_15_percent():
    for gain, damping_s, ram_dps in ((0.8, 1.5, 10.0), (1.3, 1.0, 7.0), (2.2, 0.8, 12.0), (2.6, 1.8, 6.0)):
        est, _ = _sail(gain, damping_s, ram_dps=ram_dps)
        t.true(est.gain > 0.0, (gain, est.separation, est.informative))
        t.true(abs(est.gain / gain - 1.0) <= 0.15, (gain, est.gain, est.damping_s, est.rms_deg))


def test_no_estimate_without_large_errors():
    est, _ = _sail(2.0, 1.0, steps=(2, -2), every_s=20.0)  # errors inside the deadband + 3 deg
    t.eq(est.gain, 0.0)
    t.eq(est.informative, 0)
    t.true(est.scored > 400, est.scored)


def test_ticks_that_wrap_change_nothing():
    a, _ = _sail(2.2, 0.8, ram_dps=12.0)
    b, _ = _sail(2.2, 0.8, ram_dps=12.0, t0_ms=(1 << 30) - 20000)  # wraps 20 s in
    t.near(a.gain, b.gain, 1e-6)
    t.eq(a.scored, b.scored)


def test_a_gap_restarts_the_models_not_the_sums():
    est = PilotGain()
    est.step(0, 10.0, 10.0, 0.0, 1.0, 10.0, 30.0)
    est.step(250, 10.0, 20.0, 5.0, 1.0, 10.0, 30.0)
    t.eq(est.scored, 1)
    est.step(5250, 10.0, 20.0, 9.0, 1.0, 10.0, 30.0)  # 5 s later: no prediction across the gap
    t.eq(est.scored, 1)
    est.step(5500, 10.0, 20.0, 9.0, 1.0, 10.0, 30.0)
    t.eq(est.scored, 2)


def test_the_rudder_at_its_stop_is_not_scored():
    est = PilotGain()
    est.step(0, 0.0, 40.0, 30.0, 1.0, 10.0, 30.0)
    est.step(250, 0.0, 40.0, 30.0, 1.0, 10.0, 30.0)
    est.step(500, 0.0, 40.0, 29.0, 1.0, 10.0, 30.0)
    t.eq(est.scored, 0)


def test_the_law_clips_a_high_gain_in_the_pilots_frame():
    law = LosLaw()
    pg, notes = _sail(2.2, 0.8, ram_dps=10.0, law=law)
    t.true(pg is not None and pg.clip_deg > 0.0, notes)
    t.true(abs(pg.clip_deg - 20.0 / pg.told) < 1e-6)
    t.true(7.5 < pg.clip_deg < 10.5, pg.clip_deg)
    t.true(len(notes) >= 1 and "about its compass" in notes[0], notes)


def test_the_law_leaves_a_moderate_gain_alone():
    law = LosLaw()
    pg, notes = _sail(1.0, 1.5, ram_dps=10.0, law=law)
    t.true(pg.gain > 0.0)
    t.eq(pg.clip_deg, 0.0)
    t.eq(notes, [])


def test_off_makes_nothing():
    law = LosLaw(gain_clip_deg=0.0)
    pg, notes = _sail(2.2, 0.8, law=law)
    t.true(pg is None)
    t.eq(notes, [])


def test_a_measured_gain_clips_from_the_start():
    t.eq(LosLaw().gain_clip(), 0.0)
    t.eq(LosLaw(pilot_gain=1.2).gain_clip(), 0.0)  # below gain_clip_min
    t.near(LosLaw(pilot_gain=2.0).gain_clip(), 10.0, 1e-9)
    t.eq(LosLaw(pilot_gain=2.0, gain_clip_deg=0.0).gain_clip(), 0.0)
    law = LosLaw(pilot_gain=1.7)
    pg, _ = _sail(2.6, 1.8, ram_dps=6.0, law=law)  # the learnt gain takes over once sure
    t.true(pg.clip_deg > 0.0)
    t.near(law.gain_clip(), 20.0 / pg.told, 1e-9)
    t.true(law.gain_clip() < 20.0 / 1.7)


def test_a_lower_estimate_later_keeps_the_clip_and_says_it_once():
    law = LosLaw()
    _, notes = _sail(2.2, 0.8, ram_dps=10.0, law=law)
    pg = law.gain
    t.true(pg.clip_deg > 0.0)
    before = len(notes)
    # the same pilot turned down by a person: the estimate falls below gain_clip_min
    _, later = _sail(1.0, 1.5, ram_dps=10.0, law=law, seconds=400.0)
    t.true(pg.clip_deg > 0.0)
    t.true(abs(pg.clip_deg - 20.0 / 1.6) < 1e-6 or pg.clip_deg < 20.0 / 1.6, pg.clip_deg)
    t.true(len(later) <= 2, later)


def test_a_pilot_that_reports_no_rudder_gets_no_clip():
    """Whether the ST2000+ fills the rudder field of 0x84 is to be confirmed on the boat: a field
    that stays 0 (or is missing: None) must never read as a high gain."""
    law = LosLaw()
    heading = 0.0
    notes = []
    for i in range(1200):  # 300 s of statuses, the course stepped +-20 deg every 15 s
        course = 20.0 if (i // 60) % 2 else -20.0
        heading += (course - heading) * 0.05
        for rudder in (0.0, None):
            note = law.pilot_status(i * 250, heading % 360.0, course % 360.0, rudder, 1.0)
            if note:
                notes.append(note)
    t.eq(notes, [])
    t.eq(law.gain_clip(), 0.0)
    t.true(law.gain.gain < 1.6, law.gain.gain)
