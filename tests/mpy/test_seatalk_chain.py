# The whole SeaTalk chain at byte level: St2000 -> StLink -> a wired-AND bus carrying the 9th bit
# as parity -> a fake pilot that frames with the 9th bit -> 0x84 bytes back through the firmware's
# 8-bit Framer (own echo included), as the simulator will run it.
import tpassert as T
from trackpilot.devices import seatalk as st
from trackpilot.devices import stlink as sl
from trackpilot.devices import st2000 as sp
from trackpilot.compat import wrap180

CHAR_MS = 2  # a character on the wire (2.29 ms at 4800 Bd, rounded for 1 ms steps)


class BytePilot:
    """Frames on the 9th bit, answers keys with 0x84 after 100 ms, 0x84 every second; talks
    only on an idle bus but does not check its echo (so a collision corrupts its datagram)."""

    def __init__(self, heading=120):
        self.heading = heading
        self.course = float(heading)
        self.mode = st.MODE_STANDBY
        self.cur = bytearray()
        self.queue = []  # (t_ms, datagram)
        self.tx = None  # datagram being sent
        self.tx_i = 0
        self.next_status = 0
        self.rx = []

    def on_bus(self, b, cmd, t):
        if cmd:
            self.cur = bytearray((b,))
        elif self.cur:
            self.cur.append(b)
        if len(self.cur) >= 2 and len(self.cur) == st.length_of(self.cur[1]):
            dg = bytes(self.cur)
            self.cur = bytearray()
            if dg[0] == 0x86 and st.plausible(dg):
                self.rx.append(dg)
                k = dg[2]
                if k == st.KEY_AUTO:
                    self.mode = st.MODE_AUTO
                    self.course = float(self.heading)
                elif k == st.KEY_STANDBY:
                    self.mode = st.MODE_STANDBY
                elif k in st.KEY_DELTA_DEG and self.mode == st.MODE_AUTO:
                    self.course = (self.course + st.KEY_DELTA_DEG[k]) % 360
                else:
                    return
                self.queue.append((t + 100, None))

    def want_tx(self, t):
        if t >= self.next_status:
            self.next_status = t + 1000
            self.queue.append((t, None))
        if self.tx is None and self.queue and self.queue[0][0] <= t:
            self.queue.pop(0)
            self.tx = st.encode_84(self.heading, self.course, self.mode)
            self.tx_i = 0
        return self.tx is not None


def run_chain(ms, pilot, drv, link, on_t=None, t=0):
    bus = []  # (t_end, byte, cmd_bit, writer) characters on the wire
    last_byte_t = -100
    fw_rx = []  # (t, byte) due at the firmware's RX
    firsts = 0  # bytes that went out with the command bit
    while t < ms:
        # characters that finished: everyone on the bus receives them (the firmware: 8 bits only)
        done = [c for c in bus if c[0] <= t]
        if done:
            b = 0xFF
            cmd = 0
            for c in done:
                b &= c[1]  # wired-AND: two talkers at once corrupt the byte
                cmd |= c[2]
            for c in done:
                bus.remove(c)
            pilot.on_bus(b, cmd, t)
            fw_rx.append((t, b))
            firsts += cmd
            last_byte_t = t
        for item in fw_rx:
            link.on_rx(item[1], item[0])
        fw_rx = []
        # firmware side
        if on_t:
            on_t(t)
        drv.poll(t)
        act = link.poll(t)
        if act[0] == sl.WRITE:
            bus.append((t + CHAR_MS, link.byte, st.command_bit(link.byte, link.parity), "fw"))
        # pilot side: one byte per character time on an idle bus
        if pilot.want_tx(t) and not [c for c in bus if c[3] == "pilot"]:
            if pilot.tx_i > 0 or t - last_byte_t >= 3:
                bus.append((t + CHAR_MS, pilot.tx[pilot.tx_i], 1 if pilot.tx_i == 0 else 0, "pilot"))
                pilot.tx_i += 1
                if pilot.tx_i == len(pilot.tx):
                    pilot.tx = None
        while True:
            e = link.pop_event()
            if e is None:
                break
            if e[0] == sl.EV_FAILED:
                drv.on_send_failed(e[3], e[1])
        t += 1
    return t, firsts


def _rig():
    pilot = BytePilot(120)
    drv = None
    fr = st.Framer(gap_ms=5)
    link = sl.StLink(framer=fr, rand=sl.Prng(42))
    drv = sp.St2000(send=link.send)
    link.on_datagram = drv.on_datagram
    return pilot, drv, link


def test_engage_and_steer_over_the_bus():
    pilot, drv, link = _rig()
    t, _ = run_chain(1500, pilot, drv, link)
    T.eq(drv.heading_deg, 120)
    T.eq(drv.mode, st.MODE_STANDBY)
    T.true(drv.engage(t))
    t, _ = run_chain(t + 1500, pilot, drv, link, t=t)
    T.eq(pilot.mode, st.MODE_AUTO)
    T.eq(drv.state, sp.ENGAGED)
    drv.steer_to(-23, t)
    t, firsts = run_chain(t + 6000, pilot, drv, link, t=t)
    T.eq(pilot.course, 97.0)
    T.eq(drv.course_deg, 97.0)
    T.eq(drv.state, sp.ENGAGED)  # our own echoed keystrokes were not taken for a person
    T.eq(drv.takeovers, 0)
    # every keystroke the pilot framed on the 9th bit is one the driver sent
    T.eq(len(pilot.rx), drv.keys_sent)
    T.eq(drv.keys_confirmed, drv.keys_sent - 1)  # all but Auto (confirmed by mode)
    T.eq(link.failed, 0)
    # the wire carried each datagram's first byte with the command bit, and only that one
    T.true(firsts >= drv.keys_sent + 6, "command bytes %d" % firsts)


def test_person_key_on_the_bus_is_a_takeover():
    pilot, drv, link = _rig()
    t, _ = run_chain(1500, pilot, drv, link)
    drv.engage(t)
    t, _ = run_chain(t + 1500, pilot, drv, link, t=t)

    def person(tt):
        if tt == 4000:
            pilot.queue.append((tt, None))  # the pilot head also sends its key:
            pilot.tx = st.encode_86(st.KEY_PLUS_1, 0)
            pilot.tx_i = 0

    drv.steer_to(30, t)
    t, _ = run_chain(6000, pilot, drv, link, on_t=person, t=t)
    T.eq(drv.state, sp.TAKEN_OVER)
    reasons = []
    while True:
        e = drv.pop_event()
        if e is None:
            break
        if e[0] == sp.EV_TAKEOVER:
            reasons.append(e[2])
    T.eq(reasons, ["key +1 from sender 0"])


def test_collisions_on_a_busy_bus_are_survived():
    pilot, drv, link = _rig()
    t, _ = run_chain(1500, pilot, drv, link)
    drv.engage(t)
    t, _ = run_chain(t + 1500, pilot, drv, link, t=t)
    # the pilot now sends a status every 30 ms: our keystrokes must find gaps or back off
    def busy(tt):
        if pilot.tx is None and tt % 30 == 0:
            pilot.queue.append((tt, None))

    drv.steer_to(12, t)
    t, _ = run_chain(t + 8000, pilot, drv, link, on_t=busy, t=t)
    T.eq(pilot.course, 132.0)
    T.eq(drv.state, sp.ENGAGED)
    T.true(link.collisions > 0)  # the busy bus did make us back off
    T.eq(link.failed, 0)
    print("chain: %d collisions, %d sent, %d failed, keys %d/%d confirmed" % (
        link.collisions, link.sent, link.failed, drv.keys_confirmed, drv.keys_sent))
