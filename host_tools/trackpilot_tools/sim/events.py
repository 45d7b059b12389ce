"""The simulator's internal event queue (microseconds of virtual time)."""
import heapq


class Scheduler:
    def __init__(self):
        self.q = []
        self.seq = 0
        self.now_us = 0

    def at(self, t_us, fn, *args):
        """Run fn(t_us, *args) at t_us (never before now). Returns a handle for cancel()."""
        if t_us < self.now_us:
            t_us = self.now_us
        self.seq += 1
        ev = [t_us, self.seq, fn, args]
        heapq.heappush(self.q, ev)
        return ev

    @staticmethod
    def cancel(ev):
        ev[2] = None

    def next_us(self):
        q = self.q
        while q and q[0][2] is None:
            heapq.heappop(q)
        return q[0][0] if q else None

    def run_until(self, t_us):
        """Run every event with time <= t_us, in time order (ties: scheduling order)."""
        q = self.q
        while q and q[0][0] <= t_us:
            ev = heapq.heappop(q)
            if ev[2] is None:
                continue
            self.now_us = ev[0]
            ev[2](ev[0], *ev[3])
        if t_us > self.now_us:
            self.now_us = t_us
