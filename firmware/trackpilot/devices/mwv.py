"""Wind sensor: NMEA 0183 MWV (`$--MWV,angle,R|T,speed,K|M|N,A|V*hh`) on its own UART.

    from trackpilot.devices.mwv import MwvParser
    wind = MwvParser()
    if wind.feed(chunk, len(chunk), t_ms):       # number of new valid readings
        use(wind.angle_deg, wind.speed_mps, wind.relative, wind.t_ms)

Angle: degrees 0..360 clockwise from the bow (R, relative/apparent) or from the bow for the
theoretical true wind (T). Speed converted to m/s from K (km/h), M (m/s) or N (knots).
A sentence with status V, an empty or out-of-range field or an unknown unit is counted in
`invalid` and leaves the last reading untouched (its `t_ms` ages, so the app sees staleness).
Framing and checksum come from trackpilot.devices.nmea (shared with the GNSS parser).
"""
from trackpilot.devices import nmea
from trackpilot.compat import const

_KMH_TO_MPS = 1.0 / 3600.0  # (km/h * 1000) -> m/s
_KN_TO_MPS = 1852.0 / 3600000.0  # (knots * 1000) -> m/s
_MAX_SPEED_E3 = const(200000)  # 200 units: above any real wind on a canal


class MwvParser:
    def __init__(self, maxlen=96):
        self.framer = nmea.LineFramer(maxlen)
        self.on_msg = None  # on_msg() after each decoded MWV sentence (valid or not)
        self.readings = 0
        self.invalid = 0  # MWV with status V or unusable fields
        self.other = 0  # checked sentences that are not MWV
        self.valid = False  # a reading has been received
        self.t_ms = 0  # receive time of the last valid reading
        self.angle_deg = 0.0
        self.relative = True  # R: relative to the bow (apparent); T: true
        self.speed_mps = 0.0
        # raw fields of the last MWV sentence, ints (thousandths) or None
        self.talker = 0
        self.angle_e3 = None
        self.reference = 0  # b'R' / b'T' as int
        self.speed_e3 = None
        self.unit = 0  # b'K' / b'M' / b'N' as int
        self.status = 0  # b'A' / b'V' as int

    def feed(self, data, n, t_ms):
        """Parse data[0:n] received at t_ms; return how many valid readings arrived."""
        fr = self.framer
        i = 0
        got = 0
        while i < n:
            i = fr.feed(data, i, n)
            if i < 0:
                break
            if self._sentence(fr.fields, t_ms):
                got += 1
        return got

    def _sentence(self, f, t_ms):
        if f.formatter() != nmea.FMT_MWV:
            self.other += 1
            return False
        self.talker = f.talker()
        self.angle_e3 = f.e3(1)
        self.reference = f.char(2)
        self.speed_e3 = f.e3(3)
        self.unit = f.char(4)
        self.status = f.char(5)
        if self.on_msg is not None:
            self.on_msg()
        a = self.angle_e3
        v = self.speed_e3
        u = self.unit
        ref = self.reference
        if (self.status != 0x41 or a is None or v is None or a < 0 or a > 360000 or v < 0
                or v > _MAX_SPEED_E3 or (ref != 0x52 and ref != 0x54)):
            self.invalid += 1
            return False
        if u == 0x4D:  # M
            mps = v * 0.001
        elif u == 0x4E:  # N
            mps = v * _KN_TO_MPS
        elif u == 0x4B:  # K
            mps = v * _KMH_TO_MPS
        else:
            self.invalid += 1
            return False
        self.angle_deg = (a % 360000) * 0.001
        self.speed_mps = mps
        self.relative = ref == 0x52
        self.valid = True
        self.t_ms = t_ms
        self.readings += 1
        return True
