"""The simulated ST2000+ and SeaTalk bus: vectors, parity reconstruction, keystrokes, status,
echo timing, collisions, noise, hang faults and a person's key."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))
from trackpilot_tools.sim import params, randproc, stcodec  # noqa: E402
from trackpilot_tools.sim.events import Scheduler  # noqa: E402
from trackpilot_tools.sim.seatalk_bus import SeaTalkBus  # noqa: E402
from trackpilot_tools.sim.st2000_sim import ST2000Sim  # noqa: E402

H = bytes.fromhex


def pairs(data, parities=None):
    """(byte, parity) as the firmware writes them: the command bit on the first byte only."""
    if parities is None:
        parities = [stcodec.parity_for(b, i == 0) for i, b in enumerate(data)]
    return list(zip(data, parities))


class Rig:
    def __init__(self, seed=1, **pilot_over):
        p = params.load()
        p["pilot"].update(pilot_over)
        self.sched = Scheduler()
        self.rx = []  # (t_us, byte) what the firmware's UART receives
        self.bus = SeaTalkBus(p["seatalk"], randproc.component_rng(seed, "bus"), self.sched,
                              lambda t, b: self.rx.append((t, b)))
        self.pilot = ST2000Sim(p["pilot"], randproc.component_rng(seed, "pilot"), self.sched, self.bus)
        self.t_us = 0
        self.heading = 100.0

    def run(self, until_s, heading=None):
        """Advance in 50 ms physics steps; the boat follows the rudder crudely (or a fixed heading)."""
        end = int(until_s * 1e6)
        while self.t_us < end:
            self.t_us += 50_000
            self.sched.run_until(self.t_us)
            self.pilot.control_step(0.05, self.heading if heading is None else heading)
            if heading is None:
                self.heading += 0.45 * self.pilot.rudder_deg * 0.05  # K at 2 m/s, no lag

    def write(self, data, parities=None, at_s=None):
        t = self.t_us if at_s is None else int(at_s * 1e6)
        self.bus.write_fw(t, pairs(data, parities))

    def datagrams(self, since_us=0):
        """Frame what the firmware received (8 bits: by length, as on the ESP32, for the test)."""
        out, buf = [], b""
        for t, b in self.rx:
            if t < since_us:
                continue
            if not buf and b not in (0x84, 0x9C, 0x86, 0x10):
                continue
            buf += bytes((b,))
            if len(buf) >= 2 and len(buf) == stcodec.datagram_len(buf[1]):
                out.append((t, buf))
                buf = b""
        return out


def test_codec_against_public_vectors():
    assert stcodec.encode_9c(36, 0) == H("9c011200")
    assert stcodec.encode_84(36, 0, stcodec.MODE_STANDBY, 0, 0) == H("840612000000000008")
    d = stcodec.decode_84(H("848626970200000008"))
    assert (d["heading_deg"], d["course_deg"], d["mode"], d["turning_stbd"]) == (76, 75.5, 2, True)
    assert stcodec.encode_84(76, 75.5, 2, 0, 0, turning_stbd=True) == H("848626970200000008")
    assert stcodec.encode_86(1, stcodec.KEY_PLUS_10) == H("861108f7")
    assert stcodec.encode_86(2, stcodec.KEY_MINUS_1) == H("862105fa")
    assert stcodec.encode_86(0, stcodec.KEY_STANDBY) == H("860102fd")
    assert [p for _, p in pairs(H("861108f7"))] == list("EEOO")
    assert [p for _, p in pairs(H("9c01030f"))] == list("OOEE")
    # the 9th bit the wire carries, from the parity the byte was written with
    assert [stcodec.wire_bit9(b, p) for b, p in zip(H("861108f7"), "EEOO")] == [1, 0, 0, 0]
    assert [stcodec.wire_bit9(b, p) for b, p in zip(H("9c01030f"), "OOEE")] == [1, 0, 0, 0]
    for h in range(360):
        u, vw = stcodec.encode_heading(h)
        assert stcodec.decode_heading(u, vw) == h == stcodec.decode_heading(u, vw, "knauf")


def test_echo_arrives_2_to_3_ms_after_each_write():
    r = Rig()
    r.run(0.05, heading=100)
    t0 = r.t_us
    r.write(H("86"))
    r.run(0.1, heading=100)
    (t, b), = [(t, b) for t, b in r.rx if t >= t0]
    assert b == 0x86 and 2000 <= t - t0 <= 3000


def test_status_84_and_9c_at_1hz():
    r = Rig()
    r.pilot.start(0, phase_us=300_000)
    r.run(5.2, heading=100)
    dg = r.datagrams()
    n84 = [d for _, d in dg if d[0] == 0x84]
    n9c = [d for _, d in dg if d[0] == 0x9C]
    assert len(n84) == 5 and len(n9c) == 5
    d = stcodec.decode_84(n84[-1])
    assert d["mode"] == stcodec.MODE_STANDBY
    assert abs(d["heading_deg"] - (100 + 4.0)) <= 4  # compass offset 4 deg + slow drift


def test_a_quieter_pilot_no_9c_and_no_status_after_a_key():
    """pilot.status_9c 0 and status_after_key 0: only the 0x84 once a second, also after a key."""
    r = Rig(status_9c=0, status_after_key=0)
    c0 = engage(r)
    t0 = r.t_us
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_1))
    r.run(r.t_us / 1e6 + 3.0)
    assert r.pilot.course_deg == (c0 + 1) % 360
    dg = r.datagrams(t0)
    assert not [d for _, d in dg if d[0] == 0x9C]
    t84 = [t for t, d in dg if d[0] == 0x84]
    assert len(t84) == 3 and all(800_000 <= b - a <= 1_200_000 for a, b in zip(t84, t84[1:])), t84


def engage(r):
    r.pilot.start(0, phase_us=300_000)
    r.run(1.0)
    r.write(stcodec.encode_86(1, stcodec.KEY_AUTO))
    r.run(1.5)
    assert r.pilot.mode == stcodec.MODE_AUTO
    return r.pilot.course_deg


def test_keystrokes_step_the_course_and_get_a_status_each():
    r = Rig()
    c0 = engage(r)
    assert c0 == r.pilot.compass_int() or abs(c0 - r.pilot.compass_int()) <= 2
    t0 = r.t_us
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10))
    r.run(r.t_us / 1e6 + 0.08)
    assert r.pilot.course_deg == c0  # not before the ~0.1 s key delay
    r.run(r.t_us / 1e6 + 0.1)
    assert r.pilot.course_deg == (c0 + 10) % 360
    extra = [d for t, d in r.datagrams(t0) if d[0] == 0x84 and t - t0 < 150_000]
    assert extra and stcodec.decode_84(extra[0])["course_deg"] == (c0 + 10) % 360
    r.write(stcodec.encode_86(1, stcodec.KEY_MINUS_1))
    r.run(r.t_us / 1e6 + 0.3)
    assert r.pilot.course_deg == (c0 + 9) % 360
    # the pilot steers onto the new course (crude boat: heading follows the rudder)
    r.run(r.t_us / 1e6 + 20)
    assert abs(stcodec.decode_84(r.datagrams()[-2 if r.datagrams()[-1][1][0] == 0x9C else -1][1])["course_deg"]
               - r.pilot.compass_deg) < 3


@pytest.mark.parametrize("parities", ["OEOO", "EOOO", "EEEO", "NNNN"])
def test_wrong_parity_corrupts_the_datagram_and_is_ignored(parities):
    r = Rig()
    c0 = engage(r)
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10), list(parities))
    r.run(r.t_us / 1e6 + 0.5)
    assert r.pilot.course_deg == c0
    assert r.pilot.keys_accepted == 1  # only the Auto
    # and the next good keystroke still works (the receiver resynchronises)
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_1))
    r.run(r.t_us / 1e6 + 0.5)
    assert r.pilot.course_deg == (c0 + 1) % 360


def test_collision_changes_the_echo_and_the_pilot_retries():
    r = Rig()
    r.pilot.start(0, phase_us=300_000)
    r.run(0.3, heading=100)  # the 0x84 starts at 0.300 s
    t0 = int(0.3045e6)  # the firmware talks into the 3rd character (no listen-before-talk)
    r.write(H("86110af5"), at_s=0.3045)
    r.run(0.5, heading=100)
    echo = [b for t, b in r.rx if t0 < t < t0 + 12_000]
    assert echo[:4] != list(H("86110af5"))
    assert r.bus.stats["collisions"] >= 1
    # the pilot backed off and sent its status again, intact
    assert any(d[0] == 0x84 for t, d in r.datagrams(t0 + 12_000))


def test_lost_echo_and_deaf_receiver():
    r = Rig()
    c0 = engage(r)
    r.bus.fw_tx_lost = True
    n = len(r.rx)
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10))
    r.run(r.t_us / 1e6 + 0.02)
    assert len(r.rx) == n and r.pilot.course_deg == c0
    r.bus.fw_tx_lost = False
    r.bus.fw_rx_lost = True
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10))
    r.run(r.t_us / 1e6 + 2.0)
    assert len(r.rx) == n and r.pilot.course_deg == (c0 + 10) % 360


def test_noise_corrupts_and_drops():
    r = Rig(seed=4)
    r.bus.noise_corrupt_p = 0.03
    r.bus.noise_drop_p = 0.01
    r.pilot.start(0)
    r.run(20, heading=100)
    st = r.bus.stats
    assert 4 <= st["noise_corrupt"] <= 25 and 1 <= st["noise_drop"] <= 12  # of 260 characters
    intact = [d for _, d in r.datagrams() if len(d) == 9 and d[0] == 0x84 and d[1] & 0xF == 6 and d[8] == 8]
    assert 5 < len(intact) < 20  # 20 were sent: some arrive, some are damaged


def test_hang_keys_ignores_course_keys_until_standby_auto():
    r = Rig()
    c0 = engage(r)
    r.pilot.set_hang("keys")
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10))
    r.run(r.t_us / 1e6 + 0.5)
    assert r.pilot.course_deg == c0 and r.pilot.keys_ignored == 1
    r.write(stcodec.encode_86(1, stcodec.KEY_STANDBY))
    r.run(r.t_us / 1e6 + 0.5)
    r.write(stcodec.encode_86(1, stcodec.KEY_AUTO))
    r.run(r.t_us / 1e6 + 0.5)
    assert r.pilot.hang is None and r.pilot.mode == stcodec.MODE_AUTO
    c1 = r.pilot.course_deg
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10))
    r.run(r.t_us / 1e6 + 0.5)
    assert r.pilot.course_deg == (c1 + 10) % 360


def test_hang_steer_keeps_talking_but_rudder_stops():
    r = Rig()
    c0 = engage(r)
    r.run(r.t_us / 1e6 + 10)
    r.pilot.set_hang("steer")
    rud = r.pilot.rudder_deg
    r.write(stcodec.encode_86(1, stcodec.KEY_PLUS_10))
    r.run(r.t_us / 1e6 + 5)
    assert r.pilot.course_deg == (c0 + 10) % 360  # takes the key, reports the course
    assert r.pilot.rudder_deg == rud  # but does not steer
    assert any(d[0] == 0x84 for t, d in r.datagrams(r.t_us - 2_000_000))


def test_person_key_goes_on_the_bus_with_sender_0():
    r = Rig()
    engage(r)
    t0 = r.t_us
    r.pilot.person_key(r.t_us, "standby")
    r.run(r.t_us / 1e6 + 0.5)
    assert r.pilot.mode == stcodec.MODE_STANDBY
    keys = [d for t, d in r.datagrams(t0) if d[0] == 0x86]
    assert keys == [stcodec.encode_86(0, stcodec.KEY_STANDBY)]
