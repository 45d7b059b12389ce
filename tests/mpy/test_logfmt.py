# Log format round trip under MicroPython: exact integers, CRC, wraps, events, track, damage.
import tpassert as T
from trackpilot.record import logfmt as L

_W = (1 << 30) - 1


class _Wp:
    def __init__(self, lat, lon, sp, name, r):
        self.lat_e7 = lat
        self.lon_e7 = lon
        self.speed_mps = sp
        self.name = name
        self.radius_m = r


def _rec(k):
    r = L.ControlRecord()
    r.t_ms = ((1 << 30) - 700 + 200 * k + (k % 3)) & _W  # crosses the tick wrap
    r.itow_ms = (604800000 - 600 + 200 * k) % 604800000  # crosses the week
    r.pos_valid = k % 7 != 3
    r.lat_e7 = 514951234 + 37 * k - (k * k) % 11
    r.lat_hp = ((k * 53) % 199) - 99
    r.lon_e7 = -1799999990 + 5 * k if k % 2 else 1799999990 - k  # big ints, sign flips
    r.lon_hp = 99 - (k % 199)
    r.rtk = k % 4
    r.num_sv = 20 + k % 5
    r.h_acc_m = 0.014 + 0.001 * (k % 4)
    r.heading_valid = k % 5 != 0
    r.heading_deg = (359.5 + 0.37 * k) % 360.0
    r.heading_acc_deg = 0.25
    r.vel_valid = True
    r.sog_mps = 1.5 + 0.013 * k
    r.cog_deg = (0.25 - 0.11 * k) % 360.0
    r.corr_age_s = 0.2 * (k % 5)
    r.leg = k // 4
    r.xte_m = -2.5 + 0.07 * k
    r.heading_cmd_deg = (350.0 + 1.5 * k) % 360.0
    r.speed_cmd_mps = 2.0
    r.pilot_mode = 1
    r.compass_deg = (358 + k) % 360
    r.locked_deg = (359 + k) % 360
    r.rudder_deg = -12 + k
    r.keys_sent = k // 2
    r.keys_net_deg = -(k // 2)
    r.rpm_set = 800
    r.rpm = 790 + k % 7
    r.battery_v = 50.83
    r.wind_angle_deg = (355.5 + 1.1 * k) % 360.0
    r.wind_speed_mps = 4.12
    r.alarms = (1 << 11) if k > 10 else 0
    r.mode = k % 4
    return r


_INTS = ("t_ms", "itow_ms", "lat_e7", "lat_hp", "lon_e7", "lon_hp", "rtk", "num_sv", "leg",
         "pilot_mode", "keys_sent", "keys_net_deg", "rpm_set", "rpm", "alarms", "mode",
         "pos_valid", "heading_valid", "vel_valid")
# (name, resolution, modulus)
_FLOATS = (("h_acc_m", 0.001, 0), ("heading_deg", 0.01, 360), ("heading_acc_deg", 0.01, 0),
           ("sog_mps", 0.001, 0), ("cog_deg", 0.01, 360), ("corr_age_s", 0.1, 0),
           ("xte_m", 0.01, 0), ("heading_cmd_deg", 0.01, 360), ("speed_cmd_mps", 0.001, 0),
           ("compass_deg", 0.1, 360), ("locked_deg", 0.1, 360), ("rudder_deg", 0.1, 0),
           ("battery_v", 0.01, 0), ("wind_angle_deg", 0.1, 360), ("wind_speed_mps", 0.01, 0))


def _build(n, key_every=5):
    enc = L.LogEncoder(key_every=key_every)
    out = bytearray(enc.header(fw_version="t", config_hash="c0ffee", track_id="loop",
                               reset_cause="watchdog", t0_ms=123, session=7, part=2))
    out += enc.encode_track([_Wp(514950000, 36100000, 1.5, "start", None),
                             _Wp(514951000, 36101234, 0.35, "B", 4.5)], "loop")
    recs = []
    for k in range(n):
        r = _rec(k)
        recs.append(r)
        out += enc.encode_control(r)
        if k == 4:
            out += enc.encode_event("MODE", "STANDBY->AUTO: HMI", r.t_ms)
    return bytes(out), recs, enc


def test_crc_check_value():
    T.eq(L.crc16(b"123456789"), 0x29B1)
    T.eq(L.crc16(b""), 0xFFFF)


def test_crc_nibble_table_equals_the_bitwise_crc():
    # the 16-entry table (docs/MEMORY.md) against the CRC computed a bit at a time
    data = bytes(range(256)) + bytes((255 - i) * 7 & 0xFF for i in range(256))
    for a, b in ((0, 512), (3, 4), (100, 357), (511, 512)):
        crc = 0xFFFF
        for i in range(a, b):
            crc ^= data[i] << 8
            for _ in range(8):
                crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
        T.eq(L.crc16(data, a, b), crc, "%d..%d" % (a, b))


def test_header_written_in_pieces_without_a_frame_buffer():
    import gc

    gc.collect()
    a0 = gc.mem_alloc()
    enc = L.LogEncoder()
    gc.collect()
    # besides its control and event buffers it kept a 2 KB one for the header frame (MAX_PAYLOAD)
    other = gc.mem_alloc() - a0 - len(enc._buf) - len(enc._ebuf)
    T.true(other < L.MAX_PAYLOAD, "encoder heap besides its buffers %d B" % other)
    pieces = []

    def put(b):
        pieces.append(bytes(b))
        return True

    T.true(enc.write_header(put, fw_version="t", track_id="loop", session=3, part=1, boat="x\ry"))
    T.true(len(pieces) > 10, "a line at a time")
    whole = b"".join(pieces)
    T.eq(whole, enc.header(fw_version="t", track_id="loop", session=3, part=1, boat="x\ry"))
    # the frame as the decoder reads it: tag, 2-byte length, MAGIC, version, text, CRC over all
    n = len(whole) - 5
    T.eq(whole[0], 0xB0 | L.T_HEADER)
    T.eq((whole[1] & 0x7F) | (whole[2] << 7), n)
    T.eq(whole[3:7], L.MAGIC + bytes((L.FORMAT_VERSION,)))
    c = L.crc16(whole, 0, len(whole) - 2)
    T.eq(whole[-2:], bytes((c & 0xFF, c >> 8)))
    h = list(L.iter_records(whole))[0]
    T.eq((h.type, h.get("track"), h.get("part"), h.get("boat")), ("header", "loop", "1", "x y"))
    # a write that fails stops it there
    calls = [0]

    def fail_third(b):
        calls[0] += 1
        return calls[0] < 3

    T.eq(enc.write_header(fail_third, fw_version="t"), False)
    T.eq(calls[0], 3)
    T.raises(ValueError, enc.write_header, put, fw_version="v" * 3000)


def test_quantized_keeps_no_table():
    import gc

    gc.collect()
    a0 = gc.mem_alloc()
    for f in L.FIELDS:
        L.quantized(f[0], 1.5)
    gc.collect()
    # it built a dict of every field's (scale, modulus) at the first call and kept it: 1.3 KB
    T.true(gc.mem_alloc() - a0 < 256, "kept %d B" % (gc.mem_alloc() - a0))
    T.eq(L.quantized("heading_deg", 359.996), 0.0)  # 0.01 deg, wrapped at 360
    T.near(L.quantized("sog_mps", 1.23456), 1.235, 1e-6)
    T.eq(L.quantized("t_ms", (1 << 30) + 5), 5)
    T.raises(ValueError, L.quantized, "no_such_field", 1.0)


def test_round_trip_exact():
    data, recs, enc = _build(40)
    T.eq(enc.keyframes, 8)
    got = [r for r in L.iter_records(data)]
    types = [r.type for r in got]
    T.eq(types.count("damage"), 0, "no damage in a clean log")
    T.eq(types[0], "header")
    h = got[0]
    T.eq(h.version, L.FORMAT_VERSION)
    T.eq(h.get("reset"), "watchdog")
    T.eq(h.get("config"), "c0ffee")
    T.eq(h.get("session"), "7")
    T.eq(len(h.fields), len(L.FIELDS))
    ctl = [r for r in got if r.type == "control"]
    T.eq(len(ctl), 40)
    for k in range(40):
        a = recs[k]
        b = ctl[k]
        T.eq(b.key, k % 5 == 0, "keyframe every 5")
        for name in _INTS:
            T.eq(getattr(b, name), getattr(a, name), "%s at %d" % (name, k))
        for name, res, mod in _FLOATS:
            d = getattr(b, name) - getattr(a, name)
            if mod:
                d = (d + mod / 2) % mod - mod / 2
            T.near(d, 0.0, res * 0.51 + 1e-4, "%s at %d" % (name, k))


def test_event_and_track():
    data, recs, _ = _build(8)
    ev = [r for r in L.iter_records(data) if r.type == "event"]
    T.eq(len(ev), 1)
    T.eq(ev[0].kind, "MODE")
    T.eq(ev[0].text, "STANDBY->AUTO: HMI")
    T.eq(ev[0].t_ms, recs[4].t_ms)
    tr = [r for r in L.iter_records(data) if r.type == "track"][0]
    T.eq(tr.track_id, "loop")
    T.eq([(w.lat_e7, w.lon_e7, w.name) for w in tr.waypoints],
         [(514950000, 36100000, "start"), (514951000, 36101234, "B")])
    T.eq(tr.waypoints[0].radius_m, None)
    T.near(tr.waypoints[1].radius_m, 4.5, 0.006)
    T.near(tr.waypoints[1].speed_mps, 0.35, 0.0006)


def test_long_text_cut_and_long_track_split():
    enc = L.LogEncoder()
    fr = enc.encode_event("FAULT", "x" * 500, 5)
    ev = list(L.iter_records(bytes(fr)))
    T.eq(len(ev[0].text), 200)
    wps = [_Wp(514950000 + 100 * i, 36100000 - 70 * i, 1.0, "wp%d" % i, None) for i in range(300)]
    data = enc.encode_track(wps, "long")
    got = list(L.iter_records(data))
    T.eq([r.type for r in got], ["track"])
    T.eq(len(got[0].waypoints), 300)
    T.eq(got[0].waypoints[299].lon_e7, 36100000 - 70 * 299)
    T.eq(got[0].waypoints[150].name, "wp150")


def test_bad_values_do_not_stop_logging():
    enc = L.LogEncoder()
    r = L.ControlRecord()
    r.heading_deg = float("nan")
    r.xte_m = float("inf")
    r.sog_mps = None
    got = list(L.iter_records(bytes(enc.encode_control(r))))
    T.eq(got[0].heading_deg, 0.0)
    T.eq(got[0].xte_m, 0.0)


def test_cut_and_flip_report_damage():
    data, recs, _ = _build(20)
    cut = data[: len(data) - 7]
    got = list(L.iter_records(cut))
    T.eq(got[-1].type, "damage")
    T.eq(got[-1].reason, "truncated")
    T.eq(len([r for r in got if r.type == "control"]), 19)
    # Flip one byte inside the 3rd control record: it and the deltas up to the next key are lost.
    offs = [r.offset for r in L.iter_records(data) if r.type == "control"]
    bad = bytearray(data)
    bad[offs[2] + 4] ^= 0x55
    got = list(L.iter_records(bytes(bad)))
    ctl = [r for r in got if r.type == "control"]
    T.eq([r.lat_e7 for r in ctl], [recs[k].lat_e7 for k in (0, 1) + tuple(range(5, 20))])
    dmg = [r for r in got if r.type == "damage"]
    T.eq([d.reason for d in dmg], ["bad frame", "no keyframe"])
    T.eq(dmg[1].records, 2)


def test_decoder_never_raises_on_garbage():
    seed = 12345
    buf = bytearray(600)
    for k in range(40):
        for i in range(len(buf)):
            seed = (seed * 1103515245 + 12345) & 0x7FFFFFFF
            b = (seed >> 16) & 0xFF
            buf[i] = (0xB0 + (b & 3)) if b < 64 else b
        for r in L.iter_records(bytes(buf)):
            T.true(r.type in ("damage", "control", "event", "track", "header"))
