"""A masthead wind sensor speaking NMEA MWV (relative wind) at a fixed rate, from the boat's
apparent wind with sensor noise."""
from . import nmea_enc


class WindSensor:
    def __init__(self, params, rng):
        self.p = params
        self.rng = rng
        self.period_ms = int(round(1000 / params["rate_hz"]))

    def sample(self, t_ms, apparent_speed_mps, apparent_angle_deg):
        """-> (delivery_t_ms, bytes) for a reading taken at t_ms (4800 Bd NMEA)."""
        a = (apparent_angle_deg + self.rng.gauss(0, self.p["angle_sd_deg"])) % 360.0
        s = max(0.0, apparent_speed_mps + self.rng.gauss(0, self.p["speed_sd_mps"]))
        data = nmea_enc.mwv(a, s, self.p["talker"])
        return t_ms + 1 + len(data) * 10 * 1000 // 4800, data
