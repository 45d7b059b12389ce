"""SeaTalk1 bus access: idle wait, per-byte parity, echo check, random backoff, bounded retries.

Pure logic with injected time and randomness; the asyncio shell owns the UART.

Driving contract (the shell does exactly this):
    link = StLink(framer=seatalk.Framer(), on_datagram=pilot.on_datagram, rand=Prng(seed))
    link.on_sent = pilot.on_sent  # (dg, t_ms) as soon as a datagram's echo is complete
    link.send(dg)               # queue a datagram; False when the queue is full (bounded)
    # for EVERY byte read from the SeaTalk UART, in order, with its arrival time:
    link.on_rx(byte, t_ms)      # -> False for the echo of our own bytes (consumed here); True for
                                # any other byte, which goes to the framer (if given), and each
                                # framed datagram to on_datagram(dg, t_ms)
    # then, and whenever the time given by WAIT has come:
    act = link.poll(t_ms)
      (IDLE,)              nothing queued; call poll again after send() or on_rx()
      (WAIT, until_ms)     nothing to write before until_ms (poll again then, or after on_rx)
      (WRITE, byte, par)   set the UART parity to par ("E"/"O"; uart.init(parity=0 or 1) on the
                           ESP32, which drains the TX FIFO first) and write the single byte now;
                           its echo comes back through on_rx. Call poll again afterwards.
    act[0] is one of IDLE, WAIT, WRITE; the same values are also in link.byte, link.parity,
    link.until_ms.
    ev = link.pop_event()       # (EV_SENT|EV_FAILED|EV_COLLISION, t_ms, text, datagram) or None
                                # forward EV_FAILED's datagram to pilot.on_send_failed(dg, t_ms)
poll() never returns WRITE twice without an echo, an echo timeout, or a backoff in between, and
every datagram ends in exactly one EV_SENT or EV_FAILED: the link never hangs.

Our own datagrams never reach on_datagram: each byte is written only after the previous one's
echo was consumed here, so a late echo can bring back at most one byte, never a whole datagram.
Any framed datagram is someone else's, even with our sender id (a hand remote): the pilot driver
takes a keystroke there as a person's key.

Timing defaults (4800 Bd, 11 bits a character = 2.29 ms): the bus counts as idle after
`idle_ms` = 3 ms without a received byte (>= 10 bit times = 2.08 ms, rounded up to whole ms) plus
a random 0..`extra_wait_ms`; an echo must arrive within `echo_timeout_ms` = 40 ms; a collision
(wrong byte back, or none) backs off a random `backoff_min_ms`..`backoff_max_ms` = 2..50 ms and
retries the whole datagram, at most `retries` = 5 times, then EV_FAILED.

On the ESP32 the UART hands received bytes over only after its RX timeout (ESP-IDF default 10
character times, ~23 ms at 4800 Bd; wiring_esp32 lowers it through `timeout_char`): the echo
timeout must cover that plus the event loop's latency, hence `pilot.echo_timeout_ms` (default 40).
`echo_max_ms` records the slowest echo seen, to check the margin on the boat.

`LinkHealth` turns the link's results into the app's reaction: the SeaTalk alarm after
`alarm_fails` datagrams in a row failed; "cannot steer" (-> ALARM) after `lost_fails` in a row
or `lost_ms` since the first failure without a success; OK again at the next datagram sent.

Usage with a fake bus (tests): see tests/mpy/test_seatalk_link.py.
"""
from trackpilot.compat import const, ticks_add, ticks_diff
from trackpilot.devices.seatalk import parity_for

IDLE = const(0)
WAIT = const(1)
WRITE = const(2)

EV_SENT = const(1)
EV_FAILED = const(2)
EV_COLLISION = const(3)
EV_NAMES = ("", "SENT", "FAILED", "COLLISION")

_IDLE_ACT = (IDLE,)

_S_IDLE = const(0)  # nothing to send
_S_WAIT_BUS = const(1)  # waiting for the bus to be idle
_S_WRITE = const(2)  # next byte may go out now
_S_ECHO = const(3)  # byte written, waiting for its echo
_S_BACKOFF = const(4)  # after a collision


class Prng:
    """Small seedable xorshift32 (deterministic backoff in tests and simulation). Seed the boat's
    instance from os.urandom in the wiring."""

    def __init__(self, seed=1):
        s = (seed & 0xFFFFFFFF) or 0x2545F491
        # the 32-bit state as two 16-bit halves: 32-bit values are long ints (heap) on the ESP32
        self.hi = s >> 16
        self.lo = s & 0xFFFF

    def randint(self, lo, hi):
        sh = self.hi
        sl = self.lo
        sh ^= ((sh << 13) | (sl >> 3)) & 0xFFFF  # s ^= s << 13
        sl ^= (sl << 13) & 0xFFFF
        sl ^= sh >> 1  # s ^= s >> 17
        sh ^= ((sh << 5) | (sl >> 11)) & 0xFFFF  # s ^= s << 5
        sl ^= (sl << 5) & 0xFFFF
        self.hi = sh
        self.lo = sl
        return lo + ((sh << 8) | (sl >> 8)) % (hi - lo + 1)


class StLink:
    def __init__(self, framer=None, on_datagram=None, rand=None, idle_ms=3, extra_wait_ms=0,
                 echo_timeout_ms=40, backoff_min_ms=2, backoff_max_ms=50, retries=5,
                 queue_len=4, events_len=16):
        self.framer = framer
        self.on_datagram = on_datagram
        self.on_sent = None
        self.rand = rand if rand is not None else Prng(1)
        self.idle_ms = idle_ms
        self.extra_wait_ms = extra_wait_ms
        self.echo_timeout_ms = echo_timeout_ms
        self.backoff_min_ms = backoff_min_ms
        self.backoff_max_ms = backoff_max_ms
        self.retries = retries
        self._qmax = queue_len
        self._q = []
        self._evmax = events_len
        self._ev = []
        self._s = _S_IDLE
        self._dg = None  # datagram being sent
        self._i = 0  # index of the next byte to write / the byte awaiting its echo
        self._tries = 0
        self._last_rx = None  # t_ms of the last received byte
        self._deadline = 0
        self._wait = 0  # extra idle wait drawn for this attempt
        self._reason = ""
        # what poll() asks for
        self.byte = 0
        self.parity = "E"
        self.until_ms = 0
        # counters
        self.sent = 0
        self.failed = 0
        self.collisions = 0
        self.no_echo = 0
        self.rx_bytes = 0
        self.events_dropped = 0
        self.echo_max_ms = 0  # slowest echo of our own byte seen (ms after the write)
        self._write_t = 0

    def busy(self):
        return self._s != _S_IDLE or bool(self._q)

    def send(self, dg):
        """Queue one complete datagram (bytes). False when the queue is full; ValueError when
        the bytes are not a datagram (length must match the attribute nibble)."""
        n = len(dg)
        if n < 3 or n != 3 + (dg[1] & 0x0F):
            raise ValueError("not a SeaTalk datagram: %d bytes, attribute %02x" % (n, dg[1] if n > 1 else 0))
        if len(self._q) >= self._qmax:
            return False
        self._q.append(bytes(dg))
        return True

    def pop_event(self):
        return self._ev.pop(0) if self._ev else None

    def _event(self, kind, t_ms, text):
        if len(self._ev) >= self._evmax:
            self._ev.pop(0)
            self.events_dropped += 1
        self._ev.append((kind, t_ms, text, self._dg))

    def _deliver(self, b, t_ms):
        fr = self.framer
        if fr is None:
            return
        fr.feed(b, t_ms)
        if self.on_datagram is not None:
            while fr.pending():
                self.on_datagram(fr.pop(), t_ms)

    def on_rx(self, b, t_ms):
        """Every byte the UART received (our own echo included), in order. Returns False when
        the byte was the expected echo of our own transmission, True otherwise."""
        self.rx_bytes += 1
        self._last_rx = t_ms
        if self._s == _S_ECHO:
            if b == self._dg[self._i]:
                dt = ticks_diff(t_ms, self._write_t)
                if dt > self.echo_max_ms:
                    self.echo_max_ms = dt
                self._i += 1
                if self._i == len(self._dg):
                    self.sent += 1
                    self._event(EV_SENT, t_ms, "sent")
                    if self.on_sent is not None:
                        self.on_sent(self._dg, t_ms)
                    if self.framer is not None:
                        self.framer.reset()  # the next byte starts a datagram
                    self._next(t_ms)
                else:
                    self._s = _S_WRITE
                return False
            self._collision(t_ms, "echo %02x for %02x at byte %d" % (b, self._dg[self._i], self._i))
            if self.framer is not None:
                self.framer.reset()
        self._deliver(b, t_ms)
        return True

    def _collision(self, t_ms, reason):
        self.collisions += 1
        self._tries += 1
        self._reason = reason
        self._event(EV_COLLISION, t_ms, reason)
        if self._tries > self.retries:
            self.failed += 1
            self._event(EV_FAILED, t_ms, "after %d tries: %s" % (self._tries, reason))
            self._next(t_ms)
            return
        self._s = _S_BACKOFF
        self._deadline = ticks_add(t_ms, self.rand.randint(self.backoff_min_ms, self.backoff_max_ms))

    def _next(self, t_ms):
        if self._q:
            self._dg = self._q.pop(0)
            self._tries = 0
            self._start_wait()
        else:
            self._dg = None
            self._s = _S_IDLE

    def _start_wait(self):
        self._s = _S_WAIT_BUS
        self._i = 0
        self._wait = self.idle_ms + (self.rand.randint(0, self.extra_wait_ms) if self.extra_wait_ms else 0)

    def poll(self, t_ms):
        """The next action: (IDLE,), (WAIT, until_ms) or (WRITE, byte, parity)."""
        a = self._poll(t_ms)
        if a == WRITE:
            return (WRITE, self.byte, self.parity)
        if a == WAIT:
            return (WAIT, self.until_ms)
        return _IDLE_ACT

    def _poll(self, t_ms):
        s = self._s
        if s == _S_IDLE:
            if not self._q:
                return IDLE
            self._next(t_ms)
            s = self._s
        if s == _S_BACKOFF:
            if ticks_diff(t_ms, self._deadline) < 0:
                self.until_ms = self._deadline
                return WAIT
            self._start_wait()
            s = self._s
        if s == _S_ECHO:
            if ticks_diff(t_ms, self._deadline) < 0:
                self.until_ms = self._deadline
                return WAIT
            self.no_echo += 1
            self._collision(t_ms, "no echo for byte %d (%02x)" % (self._i, self._dg[self._i]))
            return self._poll(t_ms)
        if s == _S_WAIT_BUS:
            if self._last_rx is None:
                self._last_rx = t_ms  # nothing heard yet: listen for one idle time first
            free_at = ticks_add(self._last_rx, self._wait)
            if ticks_diff(t_ms, free_at) < 0:
                self.until_ms = free_at
                return WAIT
            self._s = _S_WRITE
        # _S_WRITE: one byte, its parity carrying the command bit
        b = self._dg[self._i]
        self.byte = b
        self.parity = parity_for(b, self._i == 0)
        self._s = _S_ECHO
        self._write_t = t_ms
        self._deadline = ticks_add(t_ms, self.echo_timeout_ms)
        return WRITE

    @classmethod
    def from_config(cls, pilot_cfg, framer=None, on_datagram=None, rand=None):
        """Timing from the config's "pilot" section (keys absent there keep the defaults)."""
        kw = {}
        for k in ("idle_ms", "echo_timeout_ms", "backoff_min_ms", "backoff_max_ms", "retries"):
            if k in pilot_cfg:
                kw[k] = pilot_cfg[k]
        return cls(framer=framer, on_datagram=on_datagram, rand=rand, **kw)


H_NONE = const(0)
H_ALARM = const(1)  # raise the SeaTalk alarm
H_LOST = const(2)  # the link cannot send: the firmware cannot steer (AUTO -> ALARM)
H_OK = const(3)  # a datagram went out again: clear the alarm


class LinkHealth:
    """Counts whole datagrams (each already retried by StLink), never single collisions."""

    def __init__(self, alarm_fails=2, lost_fails=3, lost_ms=5000):
        self.alarm_fails = alarm_fails
        self.lost_fails = lost_fails
        self.lost_ms = lost_ms
        self.fails = 0  # datagrams failed in a row
        self.first_fail_ms = 0
        self.alarmed = False
        self.lost = False

    @classmethod
    def from_config(cls, pilot_cfg):
        return cls(pilot_cfg.get("link_alarm_fails", 2), pilot_cfg.get("link_lost_fails", 3),
                   pilot_cfg.get("link_lost_ms", 5000))

    def on_sent(self, t_ms):
        was = self.alarmed or self.lost
        self.fails = 0
        self.alarmed = self.lost = False
        return H_OK if was else H_NONE

    def on_failed(self, t_ms):
        self.fails += 1
        if self.fails == 1:
            self.first_fail_ms = t_ms
        h = self.poll(t_ms)
        if h == H_NONE and not self.alarmed and self.fails >= self.alarm_fails:
            self.alarmed = True
            return H_ALARM
        return h

    def poll(self, t_ms):
        """H_LOST once, when the failures have gone on too long; else H_NONE."""
        if self.lost or not self.fails:
            return H_NONE
        if self.fails >= self.lost_fails or ticks_diff(t_ms, self.first_fail_ms) >= self.lost_ms:
            self.lost = self.alarmed = True
            return H_LOST
        return H_NONE

    def reason(self, t_ms):
        return "%d datagrams in a row not sent, none for %d ms" % (
            self.fails, ticks_diff(t_ms, self.first_fail_ms))
