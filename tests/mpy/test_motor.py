# Motor link (placeholder frame), its simulated device, link loss, low battery, PWM mapping.
import tpassert as T
from trackpilot.devices import motor as m
from trackpilot.sim.motor_sim import MotorSim


def test_frames_both_formats():
    T.eq(m.encode_set(1200), b"S1200\r")
    T.eq(m.encode_set(-300), b"S-300\r")
    T.eq(m.encode_reply(1187, 48120, 0), b"R1187,48120,0\r")
    b = m.encode_set(-2, m.FMT_BINARY)
    T.eq(b, bytes((0xA5, 0x01, 0xFE, 0xFF, 0xA5 ^ 0x01 ^ 0xFE ^ 0xFF)))
    for fmt in (m.FMT_ASCII, m.FMT_BINARY):
        p = m.FrameParser(fmt)
        for rpm in (-32767, -1, 0, 1, 799, 32767):
            got = [p.feed_byte(x) for x in m.encode_set(rpm, fmt)]
            T.eq(got[-1], ("S", rpm))
            got = [p.feed_byte(x) for x in m.encode_reply(rpm, 51234, 5, fmt)]
            T.eq(got[-1], ("R", rpm, 51234, 5))
        T.eq(p.errors, 0)
    T.raises(ValueError, m.encode_set, 40000)


def test_parser_resyncs_and_is_bounded():
    for fmt in (m.FMT_ASCII, m.FMT_BINARY):
        p = m.FrameParser(fmt)
        good = m.encode_reply(500, 47000, 0, fmt)
        junk = b"\x00xyz\x5a\x81\x01R12,\xa5" + bytes(range(200))
        out = [p.feed_byte(x) for x in junk + good]
        T.eq(out[-1], ("R", 500, 47000, 0), "fmt %d" % fmt)
        T.true(p.errors > 0)
        T.true(p._n <= 32)
    # a corrupted checksum / malformed line is counted, not returned
    p = m.FrameParser(m.FMT_BINARY)
    bad = bytearray(m.encode_reply(1, 2, 3, m.FMT_BINARY))
    bad[3] ^= 1
    T.eq([p.feed_byte(x) for x in bad][-1], None)
    p = m.FrameParser()
    T.eq([p.feed_byte(x) for x in b"R1,2\r"][-1], None)
    T.eq(p.errors, 1)


def _run(link, dev, ms, t=0, dt=50):
    end = t + ms
    while t < end:
        fr = link.poll(t)
        if fr is not None:
            link.feed(dev.feed(fr, t + 5), t + 5)
        dev.step(t)
        t += dt
    return t


def test_link_with_simulated_device_keepalive_and_readback():
    for fmt in ("ascii", "binary"):
        link = m.MotorLink(fmt=fmt, keepalive_ms=200)
        dev = MotorSim(fmt=fmt, rpm_tau_s=1.0, batt_mv_full=50000)
        link.set_rpm(800)
        t = _run(link, dev, 10000)
        T.eq(link.link_ok, True)
        T.true(abs(link.rpm - 800) <= 2, "rpm read back %r" % link.rpm)
        T.true(47000 < link.batt_mv < 50000, "sag %r" % link.batt_mv)
        T.eq(link.rpm_set, 800)
        # keepalive: one frame per 200 ms when nothing changes (10 s -> 50 frames)
        T.eq(link.frames_sent, 50)
        T.eq(dev.frames, 50)
        # lag: 1 s after a step to 0 the rpm is still well above 0
        link.set_rpm(0)
        t = _run(link, dev, 1000, t)
        T.true(200 < link.rpm < 500, "lag %r" % link.rpm)
        T.eq(link.pop_event()[0], m.EV_LINK_OK)


def test_setpoint_clamps_and_rejects_garbage():
    link = m.MotorLink(rpm_min=0, rpm_max=1000)
    link.set_rpm(5000)
    T.eq(link.rpm_set, 1000)
    link.set_rpm(-20)
    T.eq(link.rpm_set, 0)
    link.set_rpm(99.6)
    T.eq(link.rpm_set, 100)
    T.raises(ValueError, link.set_rpm, float("nan"))
    T.raises(ValueError, link.set_rpm, "fast")


def test_link_loss_and_back():
    link = m.MotorLink(keepalive_ms=200, reply_timeout_ms=1000)
    dev = MotorSim()
    link.set_rpm(300)
    t = _run(link, dev, 2000)
    T.eq(link.link_ok, True)
    dev.reply = False
    t = _run(link, dev, 1500, t)
    T.eq(link.link_ok, False)
    names = []
    while True:
        e = link.pop_event()
        if e is None:
            break
        names.append(e[0])
    T.eq(names, [m.EV_LINK_OK, m.EV_LINK_LOST])
    dev.reply = True
    _run(link, dev, 500, t)
    T.eq(link.link_ok, True)
    # never any reply at all: lost after the timeout from the first frame
    link = m.MotorLink(reply_timeout_ms=1000)
    dev = MotorSim(reply=False)
    _run(link, dev, 900)
    T.eq(link.link_ok, None)
    _run(link, dev, 300, 900)
    T.eq(link.link_ok, False)
    # a link without replies (expect_replies=False) never reports a loss
    link = m.MotorLink(expect_replies=False)
    _run(link, MotorSim(reply=False), 5000)
    T.eq(link.link_ok, None)
    T.eq(link.pop_event(), None)


def test_low_battery_needs_hold_time_and_hysteresis():
    link = m.MotorLink(low_batt_mv=44000, low_batt_hyst_mv=500, low_batt_hold_ms=3000,
                       reply_timeout_ms=10000)
    link.set_rpm(0)
    link.poll(0)
    link.feed(m.encode_reply(0, 43000, 0), 0)  # a short dip under load
    link.poll(2000)
    link.feed(m.encode_reply(0, 45000, 0), 2100)
    link.poll(5000)
    T.eq(link.low_batt, False)
    link.feed(m.encode_reply(0, 43000, 0), 6000)
    link.poll(8000)
    T.eq(link.low_batt, False)
    link.feed(m.encode_reply(0, 43100, 0), 8500)
    link.poll(9001)
    T.eq(link.low_batt, True)
    link.feed(m.encode_reply(0, 44300, 0), 9500)  # above the limit but inside the hysteresis
    T.eq(link.low_batt, True)
    link.feed(m.encode_reply(0, 44600, 0), 9600)
    T.eq(link.low_batt, False)
    names = []
    while True:
        e = link.pop_event()
        if e is None:
            break
        names.append(e[0])
    T.eq(names, [m.EV_LINK_OK, m.EV_LOW_BATT, m.EV_BATT_OK])


def test_simulated_battery_drains_and_failsafe():
    dev = MotorSim(drain_mv_per_krpm_h=2000, rpm_tau_s=0.5, failsafe_ms=2000)
    dev.feed(b"S1000\r", 0)
    t = 0
    while t < 3600000:  # one hour at 1000 rpm, keepalive every second
        t += 1000
        dev.feed(b"S1000\r", t)
    T.true(abs(dev.open_mv - (51000 - 2000)) < 20, "drain %r" % dev.open_mv)
    dev.step(t + 2500)  # no frame for 2.5 s: the device falls back to 0 rpm
    T.eq(dev.setpoint, 0)
    T.eq(dev.status & 1, 1)


def test_pwm_mapping():
    T.eq(m.rpm_to_duty_u16(0, 1500), 0)
    T.eq(m.rpm_to_duty_u16(1500, 1500), 65535)
    T.eq(m.rpm_to_duty_u16(750, 1500), 32768)
    T.eq(m.rpm_to_duty_u16(-200, 1500), 0)
    T.eq(m.rpm_to_duty_u16(9999, 1500), 65535)
    T.eq(m.rpm_to_duty_u16(float("nan"), 1500), 0)
    T.eq(m.rpm_to_duty_u16(0, 1000, 6554, 58982), 6554)  # 0.5..4.5 V of a 5 V range
    T.eq(m.rpm_to_duty_u16(1000, 1000, 6554, 58982), 58982)
    T.raises(ValueError, m.rpm_to_duty_u16, 10, 0)


def test_from_config_section():
    link = m.MotorLink.from_config({"frame": "binary", "keepalive_ms": 100, "reply_timeout_ms": 900,
                                    "expect_replies": False, "rpm_max": 1200, "low_battery_v": 43.5})
    T.eq(link.fmt, m.FMT_BINARY)
    T.eq(link.low_batt_mv, 43500)
    link.set_rpm(-5000)
    T.eq(link.rpm_set, -1200)
    T.eq(link.poll(0), m.encode_set(-1200, m.FMT_BINARY))
    T.eq(link.poll(50), None)
    T.eq(link.poll(100), m.encode_set(-1200, m.FMT_BINARY))


def test_duty_and_battery_v():
    link = m.MotorLink(rpm_max=1000)
    link.set_rpm(500)
    T.eq(link.duty_u16(), 32768)
    T.eq(link.battery_v, None)
    link.feed(m.encode_reply(0, 47250, 0), 0)
    T.near(link.battery_v, 47.25, 1e-3)
