"""Cross-track error from the truth, against the track as the user gave it.

The track's waypoints are put in the simulator's plane (geodesy.LocalFrame). The leg is tracked
monotonically: move on to leg i+1 once past the end of leg i, or once nearer to leg i+1 than to
leg i (the seed report's rule). xte is the signed distance to the current leg segment
(+ = starboard of the leg direction; beyond an end, the distance to that end with the same sign).
"""
import math


class TrackGeom:
    def __init__(self, frame, waypoints_deg):
        """waypoints_deg: [(lat_deg, lon_deg), ...]"""
        self.pts = [frame.from_latlon(la, lo) for la, lo in waypoints_deg]
        self.legs = []
        s = 0.0
        for (e0, n0), (e1, n1) in zip(self.pts, self.pts[1:]):
            L = math.hypot(e1 - e0, n1 - n0)
            self.legs.append((e0, n0, (e1 - e0) / L, (n1 - n0) / L, L, s))
            s += L
        self.length_m = s
        # track distance of waypoints where the heading changes by more than 10 deg
        self.corners_m = []
        for i in range(1, len(self.legs)):
            a = math.degrees(math.atan2(self.legs[i - 1][2], self.legs[i - 1][3]))
            b = math.degrees(math.atan2(self.legs[i][2], self.legs[i][3]))
            if abs((b - a + 180.0) % 360.0 - 180.0) > 10.0:
                self.corners_m.append(self.legs[i][5])
        self.leg = 0

    def bearing_deg(self, i):
        _, _, ue, un, _, _ = self.legs[i]
        return math.degrees(math.atan2(ue, un)) % 360.0

    def _seg(self, i, e, n):
        e0, n0, ue, un, L, s0 = self.legs[i]
        de, dn = e - e0, n - n0
        along = de * ue + dn * un
        xte = de * un - dn * ue
        if along < 0.0:
            d = math.copysign(math.hypot(de, dn), xte)
        elif along > L:
            d = math.copysign(math.hypot(e - e0 - L * ue, n - n0 - L * un), xte)
        else:
            d = xte
        return d, along

    def update(self, e, n):
        """-> (leg, xte_m, track_distance_m) for the point, advancing the leg monotonically."""
        while self.leg + 1 < len(self.legs):
            d, along = self._seg(self.leg, e, n)
            d1, _ = self._seg(self.leg + 1, e, n)
            if along > self.legs[self.leg][4] or abs(d1) < abs(d):
                self.leg += 1
            else:
                break
        d, along = self._seg(self.leg, e, n)
        L, s0 = self.legs[self.leg][4], self.legs[self.leg][5]
        return self.leg, d, s0 + max(0.0, min(L, along))

    def is_straight(self, track_m):
        return all(abs(track_m - c) > 15.0 for c in self.corners_m)


def stats(values):
    if not values:
        return {"n": 0}
    a = sorted(abs(v) for v in values)
    n = len(a)
    return {"n": n, "rms_m": math.sqrt(sum(v * v for v in values) / n), "max_m": a[-1],
            "p95_m": a[min(n - 1, int(math.ceil(0.95 * n)) - 1)],
            "within_1p5_pct": 100.0 * sum(1 for v in a if v <= 1.5) / n}


def settling_distance(samples, tol_m=0.5, hold_s=10.0):
    """samples: [(t_s, dist_sailed_m, xte_m)] from engagement. Distance sailed until |xte| < tol and
    stays there for hold_s; None if it never settles."""
    start = None
    for t, d, x in samples:
        if abs(x) < tol_m:
            if start is None:
                start = (t, d)
            elif t - start[0] >= hold_s:
                return start[1] - samples[0][1]
        else:
            start = None
    return None
