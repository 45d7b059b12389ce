"""The SeaTalk1 bus at 4800 Bd as a wired-AND line (idle = mark = 1, a talker pulls it to 0).

Each character is 11 bits: start (0), 8 data bits LSB first, the 9th (command) bit, stop (1). The
firmware writes (byte, parity) pairs; its UART sends them back to back from the moment of the write
(it does not listen before talking: that is the firmware's job). The pilot and other instruments
wait for >= 10 idle bit times, check every character they send against the bus (a talker hears
itself) and on a mismatch abort and retry after a random back-off.

What every receiver sees is computed from the line level: a lone character is received as sent;
overlapping characters are sampled bit by bit by a UART that syncs on the first falling edge
(so a collision gives a different byte, a framing error (dropped), or an extra byte). Noise flips a
bit or drops a character on the wire. Received characters go to the firmware's RX (8 bits, 2-3 ms
after the start of the character) and to the 9-bit receivers (the pilot), except a talker's own.
"""
from collections import deque

from . import stcodec


class Char:
    __slots__ = ("start", "end", "value", "bit9", "talker", "nbits", "tx", "cancelled")

    def __init__(self, start, bit_us, value, bit9, talker, nbits=11, tx=None):
        self.start = start
        self.nbits = nbits
        self.end = start + nbits * bit_us
        self.value = value
        self.bit9 = bit9
        self.talker = talker
        self.tx = tx
        self.cancelled = False

    def bit(self, k):
        if k == 0:
            return 0
        if k <= 8:
            return (self.value >> (k - 1)) & 1
        if k == 9 and self.nbits == 11:
            return self.bit9
        return 1


class Transmission:
    __slots__ = ("talker", "data", "chars", "tries", "on_done")

    def __init__(self, talker, data, on_done):
        self.talker = talker
        self.data = data
        self.chars = []
        self.tries = 0
        self.on_done = on_done


class SeaTalkBus:
    def __init__(self, params, rng, sched, fw_rx):
        self.p = params
        self.rng = rng
        self.sched = sched
        self.fw_rx = fw_rx  # fw_rx(t_us, byte): bytes the firmware's UART receives
        self.bit_us = 1e6 / params["baud"]
        self.char_us = 11 * self.bit_us
        self.idle_us = params["idle_bits"] * self.bit_us
        self.pending = []  # unresolved characters, sorted by start
        self.resolved_end = -1e12
        self.recent = deque(maxlen=32)  # resolved characters, for talkers' checks
        self.receivers = []  # (name, fn(t_us, value, bit9))
        self.fw_free_us = 0.0
        self.fw_tx_lost = False  # fault: the firmware's bytes never reach the bus (no echo)
        self.fw_rx_lost = False  # fault: the firmware's RX hears nothing
        self.noise_corrupt_p = params["noise_corrupt_p"]
        self.noise_drop_p = params["noise_drop_p"]
        self.retry_limit = 5
        self.stats = {"chars": 0, "fw_chars": 0, "fw_lost": 0, "collisions": 0, "framing": 0,
                      "noise_corrupt": 0, "noise_drop": 0, "gave_up": 0, "datagrams": 0}

    def add_receiver(self, name, fn):
        self.receivers.append((name, fn))

    # ---------------------------------------------------------------- talkers
    def write_fw(self, t_us, pairs):
        """The firmware wrote [(byte, parity), ...] at t_us."""
        for value, parity in pairs:
            if self.fw_tx_lost:
                self.stats["fw_lost"] += 1
                continue
            start = max(float(t_us), self.fw_free_us)
            c = Char(start, self.bit_us, value, stcodec.wire_bit9(value, parity), "fw",
                     10 if parity == "N" else 11)
            self.fw_free_us = c.end
            self._add(c)
            self.stats["fw_chars"] += 1

    def send(self, talker, data, t_us, on_done=None, polite=True):
        """A datagram from a polite talker: wait for idle, send, check, retry on collision."""
        tx = Transmission(talker, bytes(data), on_done)
        if polite:
            self._try_send(t_us, tx)
        else:
            self._start(t_us, tx)
        return tx

    def busy_end(self, t_us):
        """End of the latest character already started at t_us."""
        end = self.resolved_end
        for c in self.pending:
            if c.start > t_us:
                break
            if c.end > end:
                end = c.end
        return end

    def _try_send(self, t_us, tx):
        end = self.busy_end(t_us)
        if end + self.idle_us > t_us:
            wait = end + self.idle_us + self.rng.uniform(0.0, 4 * self.bit_us)
            self.sched.at(wait, self._try_send, tx)
            return
        self._start(t_us, tx)

    def _start(self, t_us, tx):
        tx.chars = []
        t = float(t_us)
        for i, v in enumerate(tx.data):
            c = Char(t, self.bit_us, v, 1 if i == 0 else 0, tx.talker, 11, tx)
            tx.chars.append(c)
            self._add(c)
            t = c.end

    def _add(self, c):
        pend = self.pending
        if not pend or pend[-1].start <= c.start:
            pend.append(c)
        else:
            i = len(pend)
            while i > 0 and pend[i - 1].start > c.start:
                i -= 1
            pend.insert(i, c)
        self.sched.at(c.end, self._on_char_end, c)

    def _on_char_end(self, t_us, c):
        if c.cancelled:
            self._resolve(t_us)
            return
        tx = c.tx
        if tx is not None:
            near = [x for x in self.recent if x.start < c.end and x.end > c.start and x is not c]
            near += [x for x in self.pending if x.start < c.end and x.end > c.start and x is not c]
            seen = self._sample(c.start, near + [c]) if near else (c.value, c.bit9)
            if seen != (c.value, c.bit9):
                self.stats["collisions"] += 1
                for later in tx.chars:
                    if later.start >= c.end:
                        later.cancelled = True
                self.pending = [x for x in self.pending if not x.cancelled]
                tx.tries += 1
                if tx.tries <= self.retry_limit:
                    lo, hi = self.p["backoff_ms"]
                    self.sched.at(t_us + self.rng.uniform(lo, hi) * 1000.0, self._try_send, tx)
                else:
                    self.stats["gave_up"] += 1
                    if tx.on_done:
                        tx.on_done(t_us, False)
            elif c is tx.chars[-1]:
                self.stats["datagrams"] += 1
                if tx.on_done:
                    tx.on_done(t_us, True)
        self._resolve(t_us)

    # ---------------------------------------------------------------- the line
    def _level(self, t, group):
        for c in group:
            if c.start <= t < c.end and c.bit(int((t - c.start) / self.bit_us)) == 0:
                return 0
        return 1

    def _sample(self, start, group):
        """What a UART that synced at `start` reads: (value, bit9) or None on a framing error."""
        b = self.bit_us
        bits = [self._level(start + (k + 0.5) * b, group) for k in range(11)]
        if bits[0] != 0 or bits[10] != 1:
            return None
        v = 0
        for k in range(8):
            v |= bits[1 + k] << k
        return v, bits[9]

    def _frames(self, group):
        """Characters a receiver reads from overlapping characters: [(t_end, value, bit9)]."""
        b = self.bit_us
        edges = sorted({c.start + k * b for c in group for k in range(c.nbits)})
        g_end = max(c.end for c in group)
        out = []
        cursor = group[0].start
        while True:
            start = None
            for e in edges:
                if e >= cursor and self._level(e + 1e-3, group) == 0:
                    start = e
                    break
            if start is None or start >= g_end:
                return out
            got = self._sample(start, group)
            if got is None:
                if self._level(start + 0.5 * b, group) == 0:
                    self.stats["framing"] += 1
            else:
                out.append((start + 11 * b, got[0], got[1]))
            cursor = start + 10.5 * b

    def _resolve(self, now_us):
        pend = self.pending
        i = 0
        n = len(pend)
        while i < n:
            g_end = pend[i].end
            j = i + 1
            while j < n and pend[j].start < g_end:
                if pend[j].end > g_end:
                    g_end = pend[j].end
                j += 1
            if g_end > now_us:
                break
            group = pend[i:j]
            i = j
            self.recent.extend(group)
            if g_end > self.resolved_end:
                self.resolved_end = g_end
            if len(group) == 1:
                c = group[0]
                obs = [(c.end, c.value, c.bit9)]
            else:
                obs = self._frames(group)
            talkers = {c.talker for c in group}
            for t_end, v, b9 in obs:
                self._deliver(t_end, v, b9, talkers)
        if i:
            del pend[:i]

    def _deliver(self, t_end, v, b9, talkers):
        self.stats["chars"] += 1
        if self.noise_drop_p and self.rng.random() < self.noise_drop_p:
            self.stats["noise_drop"] += 1
            return
        if self.noise_corrupt_p and self.rng.random() < self.noise_corrupt_p:
            self.stats["noise_corrupt"] += 1
            k = self.rng.randrange(9)
            if k == 8:
                b9 ^= 1
            else:
                v ^= 1 << k
        if not self.fw_rx_lost:
            lo, hi = self.p["echo_latency_us"]
            self.fw_rx(t_end + self.rng.uniform(lo, hi), v)
        for name, fn in self.receivers:
            if name not in talkers:
                fn(t_end, v, b9)
