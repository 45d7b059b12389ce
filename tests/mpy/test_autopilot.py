# The decision core (core/autopilot.py) on its own: no asyncio, no clock, no files. Inputs with
# their time go in; events, the control record, the RPM setpoint and SeaTalk bytes come out.
import tpassert as T
from _navtracks import LAT0, LON0, track_from_m
from trackpilot import config
from trackpilot.core import modes as M
from trackpilot.core.autopilot import Autopilot
from trackpilot.devices import seatalk as st
from trackpilot.devices import stlink
from trackpilot.nav import geo
from trackpilot.nav.fix import RTK_FIXED, Fix
from trackpilot.nav.progress import Progress

T0 = (1 << 30) - 3000  # the tick counter wraps during the run


def _core(**sets):
    cfg = config.defaults()
    cfg["modes"]["correction_max_age_s"] = 0  # no NTRIP in this test
    for key, value in sets.items():
        sec, _, name = key.partition("__")
        cfg[sec][name] = value
    fix = Fix()
    core = Autopilot(cfg, (), fix, stlink.Prng(1))
    return core, fix, cfg


def _t(ms):
    return (T0 + ms) & ((1 << 30) - 1)


def _set_fix(fix, east_m, north_m, heading_deg=0.0, sog_mps=1.5):
    lat, lon = geo.move_e7(LAT0, LON0, east_m, north_m)
    fix.pos_valid = True
    fix.lat_e7, fix.lon_e7, fix.lat_hp, fix.lon_hp = lat, lon, 0, 0
    fix.rtk = RTK_FIXED
    fix.num_sv = 20
    fix.h_acc_m = 0.02
    fix.heading_valid = True
    fix.heading_deg = heading_deg
    fix.heading_acc_deg = 0.3
    fix.vel_valid = True
    fix.sog_mps = sog_mps
    fix.cog_deg = heading_deg


def _status(core, t, heading=0, mode=st.MODE_STANDBY, course=0.0):
    dg = st.encode_84(heading, course, mode)
    core.on_seatalk_rx(dg, len(dg), t)


def _events(core):
    out = []
    while True:
        ev = core.pop_event()
        if ev is None:
            return out
        out.append(ev)


def _with_track(core, t):
    trk = track_from_m([(0, 0, 1.5), (0, 200, 1.5), (100, 200, 1.5)])
    core.set_track(trk, "test", Progress(trk), t)


def test_refusal_carries_the_time_it_was_given():
    core, fix, cfg = _core()
    core.on_key("ENGAGE", "HMI", _t(5), None)
    evs = _events(core)
    T.eq(core.mm.mode, M.STANDBY)
    T.eq(core.refusal, "no valid track loaded")
    T.true(("REFUSED", "engage from HMI: no valid track loaded", _t(5)) in evs, evs)


def test_never_engages_by_itself_and_releases_the_motor():
    core, fix, cfg = _core()
    _with_track(core, _t(0))
    for i in range(50):  # 10 s of good epochs and a pilot answering
        t = _t(200 * i)
        if i % 5 == 0:
            _status(core, t)
        _set_fix(fix, 0.0, 0.3 * i)
        core.on_fix(t, 200, None)
        T.true(core.rec_ready, "a control record every epoch")
        core.rec_ready = False
        T.eq(core.rec.mode, M.STANDBY)
        T.eq(core.rpm_cmd, cfg["motor"]["release_rpm"])
        act = core.seatalk_tx(t)
        T.true(act[0] != stlink.WRITE, "no keystroke in STANDBY")
    T.eq(core.mm.mode, M.STANDBY)


def test_engage_steers_then_a_persons_key_wins():
    core, fix, cfg = _core(motor__expect_replies=False)  # no motor controller answering here
    _with_track(core, _t(0))
    for i in range(10):
        t = _t(200 * i)
        if i % 5 == 0:
            _status(core, t)
        _set_fix(fix, 0.0, 0.3 * i)
        core.on_fix(t, 200, None)
    t = _t(2000)
    core.on_key("ENGAGE", "HMI", t, None)
    T.eq(core.mm.mode, M.AUTO, [e for e in _events(core)])
    # the driver asks for Auto: the first byte of the 0x86 datagram goes to the bus
    act = core.seatalk_tx(t)
    T.eq(act[0], stlink.WRITE)
    T.eq(act[1], 0x86)
    # a guided epoch: the track speed sets the RPM
    _set_fix(fix, 0.0, 3.0)
    core.on_fix(_t(2200), 200, None)
    mc = cfg["motor"]
    T.true(core.rpm_cmd > mc["slow_rpm"], core.rpm_cmd)
    T.eq(core.rec.guided, 1)
    # the pilot reports Standby by a person's key: takeover, the motor capped, nothing more sent
    _status(core, _t(2400), mode=st.MODE_AUTO)
    core.on_seatalk_tx_done(_t(2400), _t(2400))
    dg = st.encode_86(st.KEY_STANDBY, sender=0)  # the pilot's own keypad
    core.on_seatalk_rx(dg, len(dg), _t(2500))
    evs = _events(core)
    T.eq(core.mm.mode, M.STANDBY, evs)
    T.true(any(e[0] == "PILOT" and "TAKEOVER" in e[1] for e in evs), evs)
    T.true(any(e[0] == "MODE" and "takeover" in e[1] and e[2] == _t(2500) for e in evs), evs)
    _set_fix(fix, 0.0, 3.3)
    core.on_fix(_t(2600), 200, None)
    T.true(core.rpm_cmd <= mc["slow_rpm"], core.rpm_cmd)


def test_estop_edge_latches_and_ack_needs_the_input_released():
    core, fix, cfg = _core()
    core.on_estop(True, _t(0))
    T.eq(core.mm.mode, M.ESTOP)
    core.on_key("ACK", "HMI", _t(100), None)
    T.eq(core.mm.mode, M.ESTOP, "input still active")
    core.on_estop(False, _t(150))
    core.on_key("ACK", "HMI", _t(200), None)
    T.eq(core.mm.mode, M.STANDBY)
    _set_fix(fix, 0.0, 0.0)
    core.on_fix(_t(400), 200, None)
    T.eq(core.rpm_cmd, cfg["motor"]["release_rpm"])


def test_state_to_save_is_an_output_not_a_file():
    core, fix, cfg = _core()
    _with_track(core, _t(0))
    _set_fix(fix, 0.0, 0.0)
    core.on_fix(_t(0), 200, None)
    T.eq(core.state_due, {"track_id": "test", "leg": 0, "mode": "STANDBY"})
    core.state_due = None
    core.on_fix(_t(200), 200, None)
    T.eq(core.state_due, None, "not again before STATE_SAVE_MS")
    core.restore_state({"track_id": "test", "leg": 1, "mode": "AUTO"}, _t(300))
    T.eq(core.progress.leg, 1)
    T.eq(core.mm.mode, M.STANDBY, "restored, but stays in STANDBY")
