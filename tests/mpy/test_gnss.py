# GNSS parser: framing, resync, decoding, epoch assembly (runs under MicroPython).
import tpassert as t
from _gnss_frames import Rng, eoe, hppos, nmea, pvt, relpos, rtcm3

from trackpilot import geo, gnss
from trackpilot.fix import RTK_FIXED, RTK_FLOAT, RTK_NONE, RTK_SINGLE, Fix
from trackpilot.nmea import parse_ddmm_e7, parse_e3


def _ddmm(text, hemi):
    b = text.encode()
    return parse_ddmm_e7(b, 0, len(b), ord(hemi))


def test_ddmm_exact_cases():
    t.eq(_ddmm("4807.038", "N"), 481173000)
    t.eq(_ddmm("01131.000", "E"), 115166667)
    t.eq(_ddmm("5129.4000000", "N"), 514900000)
    t.eq(_ddmm("00336.7407000", "W"), -36123450)
    t.eq(_ddmm("0000.0000030", "S"), -1)  # 0.05e-7 deg rounds half away from zero
    t.eq(_ddmm("0000.0000029", "S"), 0)
    t.eq(_ddmm("9000.0000000", "N"), 900000000)
    t.eq(_ddmm("18000.00", "W"), -1800000000)
    for bad in (("9000.0001", "N"), ("4860.0", "N"), ("48a7.0", "N"), ("48.07", "N"),
                ("4807.0", "X"), ("", "N"), ("4807.0.1", "N"), ("18000.01", "E")):
        t.eq(_ddmm(bad[0], bad[1]), None, repr(bad))


def test_ddmm_agrees_with_geo():
    rng = Rng(7)
    n = 0
    for _ in range(3000):
        deg = rng.below(180)
        hemi = "EW"[rng.below(2)] if deg >= 90 or rng.below(2) else "NS"[rng.below(2)]
        nd = rng.below(11)
        frac = ""
        for _ in range(nd):
            frac += "0123456789"[rng.below(10)]
        text = "%03d%02d.%s" % (deg, rng.below(60), frac) if hemi in "EW" else \
            "%02d%02d.%s" % (deg, rng.below(60), frac)
        t.eq(_ddmm(text, hemi), geo.ddmm_to_e7(text, hemi), text + hemi)
        n += 1
    t.eq(n, 3000)


def test_parse_e3():
    for text, want in (("12.3456", 12346), ("-0.0005", -1), ("0.0004", 0), ("7", 7000),
                       ("197.9506", 197951), (".5", 500), ("", None), ("1.2.3", None),
                       ("abc", None), ("-", None), ("1e3", None)):
        b = text.encode()
        t.eq(parse_e3(b, 0, len(b)), want, text)


def _parser(**kw):
    fix = Fix()
    return fix, gnss.GnssParser(fix, **kw)


def _feed(gp, data, t_ms=0, chunk=0):
    if not chunk:
        return gp.feed(data, len(data), t_ms)
    done = 0
    for i in range(0, len(data), chunk):
        part = data[i:i + chunk]
        done += gp.feed(part, len(part), t_ms)
    return done


def test_ubx_epoch_closes_on_pvt_same_feed():
    fix, gp = _parser(heading_offset_deg=-90.0)
    data = relpos(1000, heading_e5=12345678) + hppos(1000) + pvt(1000, g_speed=2500,
                                                                 head_mot_e5=35999000)
    t.eq(_feed(gp, data, 40), 1)
    t.eq(fix.itow_ms, 1000)
    t.eq(fix.t_ms, 40)
    t.true(fix.pos_valid)
    t.eq(fix.rtk, RTK_FIXED)
    t.eq(fix.lat_e7, 514900001)  # NAV-HPPOSLLH wins over NAV-PVT
    t.eq(fix.lon_e7, 36100002)
    t.eq(fix.lat_hp, -42)
    t.eq(fix.lon_hp, 37)
    t.near(fix.h_acc_m, 0.0123, 1e-6)
    t.true(fix.heading_valid)
    t.near(fix.heading_deg, 123.45678 - 90.0, 1e-4)
    t.near(fix.heading_acc_deg, 0.3, 1e-6)
    t.true(fix.vel_valid)
    t.near(fix.sog_mps, 2.5, 1e-6)
    t.near(fix.cog_deg, 359.99, 1e-3)
    t.eq(fix.num_sv, 20)
    t.eq(fix.utc_s, 36000)
    t.eq(fix.date, 221126)
    want = (1 << gnss.K_NAV_PVT) | (1 << gnss.K_NAV_RELPOSNED) | (1 << gnss.K_NAV_HPPOSLLH)
    t.eq(fix.sources, want)
    t.eq(gp.stats.epochs, 1)


def test_heading_needs_valid_flag_and_offset_wraps():
    fix, gp = _parser(heading_offset_deg=20.0)
    _feed(gp, relpos(1000, heading_e5=35000000, valid=False) + pvt(1000))
    t.true(not fix.heading_valid)
    _feed(gp, relpos(1200, heading_e5=35000000) + pvt(1200))
    t.true(fix.heading_valid)
    t.near(fix.heading_deg, 10.0, 1e-4)


def test_rtk_states_from_pvt():
    for carr, fix_ok, fix_type, want in ((2, 1, 3, RTK_FIXED), (1, 1, 3, RTK_FLOAT),
                                         (0, 1, 3, RTK_SINGLE), (2, 0, 3, RTK_NONE),
                                         (0, 1, 1, RTK_NONE), (0, 1, 5, RTK_NONE)):
        fix, gp = _parser()
        t.eq(_feed(gp, pvt(1000, carr=carr, fix_ok=fix_ok, fix_type=fix_type)), 1)
        t.eq(fix.rtk, want, repr((carr, fix_ok, fix_type)))
        t.eq(fix.pos_valid, want != RTK_NONE)
    fix, gp = _parser()
    _feed(gp, pvt(1000, flags3=1))  # invalidLlh
    t.true(not fix.pos_valid)


def test_new_itow_closes_previous_epoch():
    fix, gp = _parser()
    t.eq(_feed(gp, relpos(1000) + hppos(1000)), 0)
    t.eq(_feed(gp, relpos(1200)), 1)  # PVT of 1000 lost: the next iTOW closes it
    t.eq(fix.itow_ms, 1000)
    t.true(not fix.pos_valid)  # HPPOSLLH alone gives no fix status
    t.true(fix.heading_valid)
    t.eq(_feed(gp, pvt(1200)), 1)
    t.eq(fix.itow_ms, 1200)
    t.true(fix.pos_valid)


def test_eoe_takes_over_when_seen():
    # a real F9P sends NAV-PVT first; NAV-EOE closes the epochs
    fix, gp = _parser()
    t.eq(_feed(gp, pvt(1000) + relpos(1000) + hppos(1000) + eoe(1000)), 1)
    t.eq(gp.stats.late, 3)  # closed on PVT before the order was known; now the set has them
    t.eq(_feed(gp, pvt(1200) + relpos(1200) + hppos(1200)), 0)
    t.eq(_feed(gp, eoe(1200)), 1)
    t.eq(gp.stats.late, 3)
    t.true(fix.sources & (1 << gnss.K_NAV_RELPOSNED))
    t.true(fix.sources & (1 << gnss.K_NAV_EOE))
    t.eq(fix.lat_hp, -42)


def test_close_on_configured_message():
    fix, gp = _parser(close_on=("NAV-RELPOSNED",))
    t.eq(_feed(gp, pvt(1000) + hppos(1000) + relpos(1000)), 1)
    t.eq(fix.sources & 0xE, 0xE)
    t.raises(ValueError, gnss.GnssParser, Fix(), close_on=("NAV-XYZ",))


def test_epoch_timeout():
    fix, gp = _parser(epoch_timeout_ms=150)
    t.eq(_feed(gp, relpos(1000), 1000), 0)
    t.eq(gp.feed(b"", 0, 1149), 0)
    t.eq(gp.feed(b"", 0, 1150), 1)
    t.eq(fix.itow_ms, 1000)
    t.eq(_feed(gp, pvt(1000), 1160), 0)  # late for a closed epoch
    t.eq(gp.stats.late, 1)
    # ticks wrap: opened just before 2**30
    fix, gp = _parser(epoch_timeout_ms=150)
    _feed(gp, relpos(1000), (1 << 30) - 10)
    t.eq(gp.feed(b"", 0, 100), 0)
    t.eq(gp.feed(b"", 0, 140), 1)


def test_nmea_rtk_quality_and_utc_epochs():
    fix, gp = _parser()
    gga4 = nmea(b"GNGGA,120000.20,5129.4000000,N,00336.7407000,E,4,24,0.6,1.234,M,45.678,M,"
                b"1.0,0000")
    rmc = nmea(b"GNRMC,120000.20,A,5129.4000000,N,00336.7407000,E,3.000,271.5,221126,,,R,V")
    gga5 = nmea(b"GPGGA,120000.40,5129.4000000,S,00336.7407000,W,5,12,0.9,2.0,M,45.0,M,,")
    gga0 = nmea(b"INGGA,120000.60,,,,,0,00,99.99,,,,,,")
    t.eq(_feed(gp, gga4 + rmc), 0)
    t.eq(_feed(gp, gga5), 1)  # new UTC time closes 120000.20
    t.eq(fix.rtk, RTK_FIXED)
    t.eq(fix.lat_e7, 514900000)
    t.eq(fix.lon_e7, 36123450)
    t.eq(fix.height_mm, 46912)
    t.eq(fix.num_sv, 24)
    t.eq(fix.utc_s, 43200)
    t.eq(fix.date, 221126)
    t.near(fix.sog_mps, 3.0 * 1852 / 3600, 1e-5)
    t.near(fix.cog_deg, 271.5, 1e-4)
    t.true(fix.vel_valid)
    seen = []
    gp.on_epoch = lambda: seen.append((fix.rtk, fix.lat_e7))
    # two GGA-led epochs closed by a new time: the learnt set is now {GGA}, which closes
    # the no-fix epoch at once (no wait for the next second)
    t.eq(_feed(gp, gga0), 2)
    t.eq(seen[0], (RTK_FLOAT, -514900000))
    t.eq(gp.flush(0), 0)
    t.eq(fix.rtk, RTK_NONE)
    t.true(not fix.pos_valid)
    t.eq(gp.stats.bad_field, 0)  # a no-fix GGA with empty fields is normal, not bad
    # closing on the configured NMEA message: no one-epoch delay
    fix, gp = _parser(close_on=("RMC",))
    t.eq(_feed(gp, gga4 + rmc), 1)
    t.eq(fix.rtk, RTK_FIXED)


def test_rmc_modes_and_hdt_ths():
    for mode, want in ((b"F", RTK_FLOAT), (b"R", RTK_FIXED), (b"A", RTK_SINGLE),
                       (b"D", RTK_SINGLE), (b"N", RTK_NONE), (b"E", RTK_NONE)):
        fix, gp = _parser(close_on=("RMC",))
        _feed(gp, nmea(b"GPRMC,101010.00,A,5129.40,N,00336.74,E,0.5,10.0,010126,,," + mode))
        t.eq(fix.rtk, want, repr(mode))
    fix, gp = _parser(close_on=("HDT",), heading_offset_deg=1.5)
    _feed(gp, nmea(b"GPHDT,359.000,T"))
    t.true(fix.heading_valid)
    t.near(fix.heading_deg, 0.5, 1e-4)
    fix, gp = _parser(close_on=("THS",))
    _feed(gp, nmea(b"GNTHS,77.52,A"))
    t.true(fix.heading_valid)
    t.near(fix.heading_deg, 77.52, 1e-4)
    _feed(gp, nmea(b"GNTHS,77.52,V"))
    t.true(not fix.heading_valid)
    # NAV-RELPOSNED beats HDT in one epoch
    fix, gp = _parser()
    _feed(gp, nmea(b"GPHDT,10.0,T") + relpos(1000, heading_e5=2000000) + pvt(1000))
    t.near(fix.heading_deg, 20.0, 1e-4)


def test_mixed_ubx_nmea_epoch_and_late_nmea():
    fix, gp = _parser()
    gga = nmea(b"GNGGA,100000.00,5129.4000000,N,00336.7407000,E,4,24,0.6,1.0,M,45.0,M,1.0,0000")
    # NMEA before PVT joins the epoch (same UTC); NMEA after the closing PVT is late
    t.eq(_feed(gp, relpos(1000) + gga + pvt(1000)), 1)
    t.true(fix.sources & (1 << gnss.K_GGA))
    t.eq(gp.stats.late, 0)
    _feed(gp, gga)
    t.eq(gp.stats.late, 1)
    # a GGA of another second while the UBX epoch is open closes it
    gga1 = nmea(b"GNGGA,100001.00,5129.4,N,00336.7,E,1,5,1.0,1.0,M,45.0,M,,")
    t.eq(_feed(gp, relpos(1200) + gga1), 1)


MIXED = None


def _mixed():
    return (b"\x00\xff garbage " + nmea(b"GPGSV,1,1,01,01,03,161,40") + relpos(1000) +
            rtcm3(bytes(range(40))) + hppos(1000) +
            nmea(b"GNGGA,100000.00,5129.4,N,00336.7,E,4,24,0.6,1.0,M,45.0,M,1.0,0000") +
            pvt(1000) + b"\xb5\x62\x01" + pvt(1200) + b"$GPGG" + relpos(1400) + pvt(1400) +
            nmea(b"GNRMC,100000.40,A,5129.4,N,00336.7,E,0.1,1.0,221126,,,F") +
            relpos(1600) + pvt(1600) + bytes(400))


def _kinds(data, chunk):
    fix, gp = _parser()
    seen = []
    gp.on_msg = lambda k: seen.append(k)
    fixes = []
    gp.on_epoch = lambda: fixes.append((fix.itow_ms, fix.lat_e7, fix.lat_hp, fix.rtk,
                                        fix.heading_valid, fix.sources))
    n = _feed(gp, data, 0, chunk)
    return seen, fixes, n, gp.stats


def test_chunking_does_not_matter():
    data = _mixed()
    ref = _kinds(data, 0)
    t.eq([f[0] for f in ref[1]], [1000, 1200, 1400, 1600])
    t.eq(ref[2], 4)
    t.eq(ref[3].ck_err, 1)  # "B5 62 01" + PVT: one failed header, then the PVT found again
    for chunk in (1, 2, 7, 64, 511):
        got = _kinds(data, chunk)
        t.eq(got[0], ref[0], "chunk %d" % chunk)
        t.eq(got[1], ref[1], "chunk %d" % chunk)
    k = ref[0]
    t.eq(k.count(gnss.K_NAV_PVT), 4)
    t.eq(k.count(gnss.K_RTCM3), 1)
    t.eq(k.count(gnss.K_NMEA_OTHER), 1)
    t.eq(k.count(gnss.K_RMC), 1)


def test_resync_after_cut_frames():
    fix, gp = _parser()
    g = nmea(b"GPGGA,100000.00,5129.4,N,00336.7,E,1,5,1.0,1.0,M,45.0,M,,")
    p = pvt(2000)
    # UBX cut by NMEA, NMEA cut by UBX, RTCM cut by UBX
    data = p[:30] + g + g[:20] + p + rtcm3(b"\x3e\xd0" + bytes(30))[:15] + pvt(2200)
    seen = []
    gp.on_msg = lambda k: seen.append(k)
    _feed(gp, data)
    t.eq(seen, [gnss.K_GGA, gnss.K_NAV_PVT, gnss.K_NAV_PVT])


def test_oversize_frames_skipped_by_length():
    from trackpilot.ubxcfg import ubx_frame
    big = ubx_frame(0x01, 0x35, bytes(1300))  # NAV-SAT: longer than the buffer, skipped
    bad = bytearray(ubx_frame(0x01, 0x35, bytes(1200)))
    bad[300] ^= 1
    odd = ubx_frame(0x01, 0x99, bytes(1200))  # unknown long message: taken as garbage
    data = (big + pvt(1000) + bytes(bad) + pvt(1200) + rtcm3(bytes(1023)) + odd + pvt(1400) +
            rtcm3(b"\x3e\xd0" + bytes(900))[:500] + pvt(1600))
    for chunk in (0, 5, 333):
        fix, gp = _parser()
        seen = []
        gp.on_msg = lambda k: seen.append(k)
        _feed(gp, data, 0, chunk)
        t.eq(seen, [gnss.K_UBX_OTHER, gnss.K_NAV_PVT, gnss.K_NAV_PVT, gnss.K_RTCM3,
                    gnss.K_NAV_PVT], "chunk %d" % chunk)
        t.eq(gp.stats.oversize, 2)
        t.eq(gp.stats.ck_err, 1)
        t.eq(gp.rtcm.length, 1023)
        # the cut RTCM3 frame waits for its length; the PVT behind it is found once it is in
        gp.feed(bytes(600), 600, 0)
        t.eq(seen[-1], gnss.K_NAV_PVT)
        t.eq(gp.pvt.itow_ms, 1600)


def test_crc24q_check_value():
    t.eq(gnss.crc24q(b"123456789", 0, 9), 0xCDE703)


def test_bad_fields_are_safe():
    fix, gp = _parser(close_on=("GGA",))
    t.eq(_feed(gp, nmea(b"GPGGA,100000.00,51x9.4,N,00336.7,E,4,5,1.0,1.0,M,45.0,M,,")), 1)
    t.true(not fix.pos_valid)
    t.eq(gp.stats.bad_field, 1)
    t.eq(_feed(gp, nmea(b"GPGGA,1000,5129.4,N")), 1)  # short: no UTC, no fields
    t.true(not fix.pos_valid)
    # a length a decoded message never has: searched past at once (no wait for 91 bytes)
    from trackpilot.ubxcfg import ubx_frame
    seen = []
    gp.on_msg = lambda k: seen.append(k)
    _feed(gp, ubx_frame(0x01, 0x07, bytes(91))[:20] + pvt(5000))
    t.eq(seen, [gnss.K_NAV_PVT])
    t.eq(gp.stats.unknown, 0)


def test_gpsd_comment_lines():
    fix, gp = _parser(skip_comments=True)
    p = bytearray(pvt(3000, lat_e7=0x230A23 + 0x23000000))  # payload holds "#\n#"
    seen = []
    gp.on_msg = lambda k: seen.append(k)
    data = b"# comment $GPGGA,x*00\n#\n" + bytes(p) + b"\n# not a comment: mid-stream is garbage"
    _feed(gp, data)
    t.eq(seen, [gnss.K_NAV_PVT])
    t.eq(gp.pvt.lat_e7, 0x230A23 + 0x23000000)
    t.eq(gp.stats.comments, 3)
    fix, gp = _parser()
    _feed(gp, b"# x $GPHDT,1.0,T*00\n")
    t.eq(gp.stats.comments, 0)


def test_hppos_high_precision_parts_outside_99_are_rejected():
    """Issue 14.13: lat_hp/lon_hp are -99..99 (1e-9 deg); a frame outside is not taken."""
    for lat_hp, lon_hp in ((120, 0), (0, -100), (-128, 127)):
        fix, gp = _parser()
        data = relpos(1000) + hppos(1000, lat_e7=514900777, lat_hp=lat_hp, lon_hp=lon_hp) + pvt(1000)
        t.eq(_feed(gp, data), 1)
        t.true(fix.pos_valid)
        t.true(fix.lat_e7 != 514900777, "HPPOSLLH with lat_hp %d lon_hp %d taken" % (lat_hp, lon_hp))
        t.eq((fix.lat_hp, fix.lon_hp), (0, 0))
    fix, gp = _parser()
    t.eq(_feed(gp, relpos(1000) + hppos(1000, lat_e7=514900777, lat_hp=99, lon_hp=-99) + pvt(1000)), 1)
    t.eq((fix.lat_e7, fix.lat_hp, fix.lon_hp), (514900777, 99, -99))


_ORDERS = (("PVT", "REL", "HP"), ("PVT", "HP", "REL"), ("REL", "PVT", "HP"),
           ("REL", "HP", "PVT"), ("HP", "PVT", "REL"), ("HP", "REL", "PVT"),
           ("PVT", "REL"), ("REL", "PVT"))


def _epoch_bytes(order, itow, with_eoe):
    out = b""
    for name in order:
        if name == "PVT":
            out += pvt(itow)
        elif name == "REL":
            out += relpos(itow, heading_e5=4500000 + itow % 1000)
        else:
            out += hppos(itow)
    return out + (eoe(itow) if with_eoe else b"")


def test_any_order_with_or_without_eoe_at_any_rate():
    # issue 12: a PVT-first stream without EOE dropped every RELPOSNED as late before
    for order in _ORDERS:
        for with_eoe in (False, True):
            for period_ms in (40, 100, 200, 1000):
                fix, gp = _parser()
                seen = []
                gp.on_epoch = lambda: seen.append((fix.itow_ms, fix.heading_valid, fix.lat_hp))
                lag = []
                for k in range(12):
                    itow = 100000 + k * period_ms
                    n = _feed(gp, _epoch_bytes(order, itow, with_eoe), k * period_ms)
                    lag.append(n)
                    if k >= 1:  # from the second epoch: closed by its own last message
                        t.eq(n, 1, repr((order, with_eoe, period_ms, k)))
                        t.eq(seen[-1][0], itow)
                        t.true(seen[-1][1], repr((order, with_eoe, period_ms, k)))
                        t.eq(seen[-1][2], -42 if "HP" in order else 0)
                # at most the first epoch loses its later messages
                t.true(gp.stats.late <= len(order), repr((order, with_eoe, gp.stats.late)))
                t.eq(gp.interval_ms, period_ms)


def test_nmea_only_epochs_close_on_their_last_sentence():
    fix, gp = _parser()
    n_last = []
    for k in range(6):
        hhmmss = b"1200%02d.00" % k
        gga = nmea(b"GNGGA," + hhmmss + b",5129.4,N,00336.7,E,4,24,0.6,1.0,M,45.0,M,1.0,0000")
        rmc = nmea(b"GNRMC," + hhmmss + b",A,5129.4,N,00336.7,E,3.0,271.5,221126,,,R,V")
        _feed(gp, gga, k * 1000)
        n_last.append(_feed(gp, rmc, k * 1000 + 30))
    t.eq(n_last[3:], [1, 1, 1])  # the set {GGA, RMC} learnt after two epochs
    t.eq(fix.utc_s, 43205)
    t.eq(gp.interval_ms, 1000)


def test_learnt_set_follows_a_changed_stream():
    # HPPOSLLH switched off mid-run: after two short epochs the set forgets it
    fix, gp = _parser()
    for k in range(4):
        _feed(gp, _epoch_bytes(("REL", "HP", "PVT"), 1000 + 200 * k, False), 200 * k)
    closes = []
    for k in range(4, 10):
        closes.append(_feed(gp, _epoch_bytes(("PVT", "REL"), 1000 + 200 * k, False), 200 * k))
    t.eq(closes[-3:], [1, 1, 1])
    t.true(fix.heading_valid)


def test_epoch_timeout_grows_with_a_slow_rate():
    fix, gp = _parser(epoch_timeout_ms=150)
    for k in range(3):  # learn a 1 Hz rate with PVT + RELPOSNED
        _feed(gp, pvt(1000 + 1000 * k) + relpos(1000 + 1000 * k), 1000 * k)
    t.eq(gp.interval_ms, 1000)
    t.eq(_feed(gp, relpos(4000), 3000), 0)  # PVT of this epoch lost
    t.eq(gp.feed(b"", 0, 3400), 0)  # 150 ms would have cut a 1 Hz epoch short
    t.eq(gp.feed(b"", 0, 3750), 1)
