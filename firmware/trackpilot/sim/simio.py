"""Simulation adapter: a virtual clock for asyncio and streams that are pipes to the simulator.

This is the only firmware code that exists for simulation besides `wiring_sim.py`. It implements
docs/SIM_PROTOCOL.md. The application's tasks are the ones the ESP32 runs; they read `SimStream`s
through `asyncio.StreamReader` exactly as they read UARTs there.

How the lockstep works: asyncio asks its IO queue to wait `dt` ms when every task is blocked. We
replace that wait: instead of sleeping, report what the firmware wrote to the simulator, read the
next STEP (the new virtual time and the bytes that arrived), and poll the streams. asyncio's clock
(`asyncio.core.ticks`) is replaced by the virtual clock, so `sleep_ms` wakes in virtual time.

Usage (sim_main.py):
    link = SimLink(sys.stdin.buffer, sys.stdout.buffer)
    link.install()                    # patch asyncio's clock and IO wait
    gnss = link.stream(DEV_GNSS)      # an io.IOBase: read/readinto/write/ioctl
"""
import io
import struct
import sys

from trackpilot.compat import TICKS_MASK

DEV_GNSS = 1
DEV_SEATALK = 2
DEV_MOTOR = 3
DEV_WIND = 4
DEV_IO = 5
DEV_TELEMETRY = 6
DEV_NMEA_OUT = 7

_MAGIC = 0xA5
_KIND_STEP = 0x53  # 'S'
_KIND_REPORT = 0x52  # 'R'
_HDR = "<BBIIB"
_HDR_LEN = 11
_NO_WAKE = 0xFFFFFFFF

_POLL = 3  # MP_STREAM_POLL
_POLLIN = 1
_POLLOUT = 4
_RX_LIMIT = 16384  # bytes buffered per stream before the oldest are dropped (as a UART FIFO would)


class SimStream(io.IOBase):
    """One device's byte stream. RX filled by the simulator, TX collected for the next report."""

    def __init__(self, dev):
        self.dev = dev
        self.rx = bytearray()
        self.tx = bytearray()
        self.parity = None  # SeaTalk: the parity the next written bytes go out with
        self.dropped = 0

    # the UART API the application uses
    def init(self, baudrate=None, bits=8, parity=None, stop=1, **kw):
        """Like machine.UART.init: on the ESP32 this waits for the TX FIFO to drain, so a parity
        change applies to the bytes written after it. parity: None, 0 (even) or 1 (odd)."""
        self.parity = parity

    def any(self):
        return len(self.rx)

    def read(self, n=-1):
        if not self.rx:
            return None
        if n is None or n < 0 or n >= len(self.rx):
            out = bytes(self.rx)
            self.rx = bytearray()
            return out
        out = bytes(self.rx[:n])
        self.rx = self.rx[n:]
        return out

    def readinto(self, buf, n=-1):
        if not self.rx:
            return None
        if n < 0 or n > len(buf):
            n = len(buf)
        if n > len(self.rx):
            n = len(self.rx)
        buf[:n] = self.rx[:n]
        self.rx = self.rx[n:]
        return n

    def write(self, data):
        if self.dev == DEV_SEATALK:
            # each byte travels with the parity it was written with (E/O), see SIM_PROTOCOL.md
            p = 0x45 if self.parity == 0 else (0x4F if self.parity == 1 else 0x4E)
            for b in data:
                self.tx.append(b)
                self.tx.append(p)
        else:
            self.tx.extend(data)
        return len(data)

    def ioctl(self, req, arg):
        if req == _POLL:
            ready = 0
            if arg & _POLLIN and self.rx:
                ready |= _POLLIN
            if arg & _POLLOUT:
                ready |= _POLLOUT
            return ready
        return -1  # not a file descriptor, no other requests

    def deliver(self, data):
        self.rx.extend(data)
        over = len(self.rx) - _RX_LIMIT
        if over > 0:
            self.rx = self.rx[over:]
            self.dropped += over


class SimLink:
    """The protocol endpoint and virtual clock."""

    def __init__(self, fin, fout, tick_base=(1 << 30) - 60000):
        self.fin = fin
        self.fout = fout
        self.tick_base = tick_base
        self.t_ms = 0  # virtual ms since the start of the simulation
        self.streams = {}
        self.closed = False
        self.reports = 0
        self._aio_ticks = 0  # asyncio's virtual clock (in asyncio's own tick period), see install()
        self._aio_ticks_add = None

    def stream(self, dev):
        s = self.streams.get(dev)
        if s is None:
            s = SimStream(dev)
            self.streams[dev] = s
        return s

    def ticks_ms(self):
        """The application's clock: wraps at 2**30 like the ESP32's."""
        return (self.tick_base + self.t_ms) & TICKS_MASK

    def _asyncio_ticks(self):
        return self._aio_ticks

    # ------------------------------------------------------------------ protocol
    def _read_exact(self, n):
        buf = b""
        while len(buf) < n:
            chunk = self.fin.read(n - len(buf))
            if not chunk:
                return None
            buf += chunk
        return buf

    def report(self, wake_ms):
        chunks = []
        for dev in sorted(self.streams):
            s = self.streams[dev]
            if s.tx:
                chunks.append((dev, s.tx))
        out = bytearray(struct.pack(_HDR, _MAGIC, _KIND_REPORT, self.t_ms, wake_ms, len(chunks)))
        for dev, data in chunks:
            out.extend(struct.pack("<BH", dev, len(data)))
            out.extend(data)
        for dev, data in chunks:
            self.streams[dev].tx = bytearray()
        self.fout.write(out)
        self.fout.flush()
        self.reports += 1

    def read_step(self):
        """Block until the next STEP; deliver its bytes. False when the simulator has closed."""
        hdr = self._read_exact(_HDR_LEN)
        if hdr is None:
            self.closed = True
            return False
        magic, kind, t_ms, _wake, n = struct.unpack(_HDR, hdr)
        if magic != _MAGIC or kind != _KIND_STEP:
            raise ValueError("sim protocol: bad frame header %r" % hdr)
        if t_ms < self.t_ms:
            raise ValueError("sim protocol: time went back from %d to %d" % (self.t_ms, t_ms))
        if self._aio_ticks_add is not None:
            self._aio_ticks = self._aio_ticks_add(self._aio_ticks, t_ms - self.t_ms)
        self.t_ms = t_ms
        for _ in range(n):
            ch = self._read_exact(3)
            if ch is None:
                self.closed = True
                return False
            dev, length = struct.unpack("<BH", ch)
            data = self._read_exact(length) if length else b""
            if data is None:
                self.closed = True
                return False
            self.stream(dev).deliver(data)
        return True

    # ------------------------------------------------------------------ asyncio adapter
    def install(self):
        import asyncio
        from asyncio import core

        # asyncio's clock becomes virtual, advanced step by step with asyncio's own ticks_add, so it
        # wraps at asyncio's period (2**62 or 2**30 with the unix port's C scheduler, 2**29 with the
        # pure-Python port) and stays a small int on a 32-bit build. It starts a quarter period
        # ahead of the real clock, which a C scheduler still uses for tasks it pushes as "run now":
        # those then sort as due (for up to a quarter period of drift between the two clocks).
        quarter = (core.ticks_add(0, -1) >> 2) + 1
        self._aio_ticks = core.ticks_add(core.ticks(), quarter)
        self._aio_ticks_add = core.ticks_add
        core.ticks = self._asyncio_ticks
        q = core._io_queue
        link = self

        def wait_io_event(dt):
            # Every task waits. Report, get the next STEP, then wake the tasks whose stream is ready.
            # (asyncio's own poll costs ~0.6 ms per call on Python stream objects, hence this.)
            if dt != 0 and not link.closed:
                link.report(_NO_WAKE if dt < 0 else link.t_ms + dt)
                if not link.read_step():
                    link.on_closed()
            link.wake_ready(q, core)

        q.wait_io_event = wait_io_event
        return asyncio

    def wake_ready(self, q, core):
        """Mirror of asyncio's IOQueue.wait_io_event for SimStreams (always writable)."""
        if not q.map:
            return
        for key in list(q.map):
            sm = q.map[key]
            s = sm[2]
            if sm[0] is not None and s.rx:
                core._task_queue.push(sm[0])
                sm[0] = None
            if sm[1] is not None:
                core._task_queue.push(sm[1])
                sm[1] = None
            if sm[0] is None and sm[1] is None:
                q._dequeue(s)
            elif sm[0] is None:
                q.poller.modify(s, _POLLOUT)
            else:
                q.poller.modify(s, _POLLIN)

    def on_closed(self):
        """The simulator closed stdin: the application is asked to stop (set by the app)."""
        self.closed = True
        if self.stop_callback:
            self.stop_callback()

    stop_callback = None


def stderr(msg):
    sys.stderr.write(msg + "\n")
