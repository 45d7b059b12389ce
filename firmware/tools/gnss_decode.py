# Decode a raw GNSS capture with the firmware's own parser; runs under MicroPython (or CPython).
# Usage: micropython firmware/tools/gnss_decode.py FILE [--fixes] [--chunk N] [--offset DEG]
#        (the host command `trackpilot gnss decode FILE` runs this under $MICROPYTHON)
# Prints one JSON object per message (or per epoch with --fixes) to stdout and the parser's
# counters as one JSON object to stderr. Every number is printed from the parser's integers with
# integer arithmetic, so a single-precision interpreter prints the same digits. gpsd-style '#'
# lines between frames are skipped.
import sys

from trackpilot.devices import gnss
from trackpilot.nav.fix import RTK_NAMES, Fix


def fx(v, d):
    """int v scaled by 10**-d as an exact decimal string; None -> null."""
    if v is None:
        return "null"
    if d == 0:
        return "%d" % v
    sign = "-" if v < 0 else ""
    v = -v if v < 0 else v
    p = 10 ** d
    frac = "%d" % (v % p)
    return "%s%d.%s%s" % (sign, v // p, "0" * (d - len(frac)), frac)


def qs(c):
    """a byte value as a JSON string, 0 -> null."""
    if not c:
        return "null"
    return '"%s"' % chr(c)


def talker(t):
    return '"%s%s"' % (chr(t >> 8), chr(t & 0xFF))


def bit(v, n):
    return "%d" % ((v >> n) & 1)


def ms_e3(ms):
    return fx(ms, 3)


def nav_pvt(r):
    return ('"iTOW":%s,"year":%d,"month":%d,"day":%d,"hour":%d,"min":%d,"second":%d,'
            '"validDate":%s,"validTime":%s,"fullyResolved":%s,"validMag":%s,"tAcc":%s,"nano":%s,'
            '"fixType":%d,"gnssFixOk":%s,"diffSoln":%s,"headVehValid":%s,"carrSoln":%d,'
            '"numSV":%d,"lon":%s,"lat":%s,"height":%s,"hMSL":%s,"hAcc":%s,"vAcc":%s,'
            '"velN":%s,"velE":%s,"velD":%s,"gSpeed":%s,"headMot":%s,"sAcc":%s,"headAcc":%s,'
            '"pDOP":%s,"invalidLlh":%s,"headVeh":%s,"magDec":%s,"magAcc":%s') % (
        ms_e3(r.itow_ms), r.year, r.month, r.day, r.hour, r.min, r.sec,
        bit(r.valid, 0), bit(r.valid, 1), bit(r.valid, 2), bit(r.valid, 3),
        fx(r.t_acc_ns, 9), fx(r.nano_ns, 9), r.fix_type, bit(r.flags, 0), bit(r.flags, 1),
        bit(r.flags, 5), (r.flags >> 6) & 3, r.num_sv, fx(r.lon_e7, 7), fx(r.lat_e7, 7),
        fx(r.height_mm, 3), fx(r.hmsl_mm, 3), fx(r.h_acc_mm, 3), fx(r.v_acc_mm, 3),
        fx(r.vel_n_mms, 3), fx(r.vel_e_mms, 3), fx(r.vel_d_mms, 3), fx(r.g_speed_mms, 3),
        fx(r.head_mot_e5, 5), fx(r.s_acc_mms, 3), fx(r.head_acc_e5, 5), fx(r.pdop_e2, 2),
        bit(r.flags3, 0), fx(r.head_veh_e5, 5), fx(r.mag_dec_e2, 2), fx(r.mag_acc_e2, 2))


def nav_relposned(r):
    f = r.flags
    return ('"version":%d,"refStationID":%d,"iTOW":%s,"relPosN":%s,"relPosE":%s,"relPosD":%s,'
            '"relPosLength":%s,"relPosHeading":%s,"accN":%s,"accE":%s,"accD":%s,'
            '"accLength":%s,"accHeading":%s,"gnssFixOK":%s,"diffSoln":%s,"relPosValid":%s,'
            '"carrSoln":%d,"isMoving":%s,"refPosMiss":%s,"refObsMiss":%s,'
            '"relPosHeadingValid":%s,"relPosNormalized":%s') % (
        r.version, r.ref_station_id, ms_e3(r.itow_ms),
        fx(r.n_cm * 100 + r.hp_n_01mm, 4), fx(r.e_cm * 100 + r.hp_e_01mm, 4),
        fx(r.d_cm * 100 + r.hp_d_01mm, 4), fx(r.length_cm * 100 + r.hp_length_01mm, 4),
        fx(r.heading_e5, 5), fx(r.acc_n_01mm, 4), fx(r.acc_e_01mm, 4), fx(r.acc_d_01mm, 4),
        fx(r.acc_length_01mm, 4), fx(r.acc_heading_e5, 5), bit(f, 0), bit(f, 1), bit(f, 2),
        (f >> 3) & 3, bit(f, 5), bit(f, 6), bit(f, 7), bit(f, 8), bit(f, 9))


def nav_hpposllh(r):
    return ('"version":%d,"invalidLlh":%s,"iTOW":%s,"lon":%s,"lat":%s,"height":%s,"hMSL":%s,'
            '"hAcc":%s,"vAcc":%s') % (
        r.version, bit(r.flags, 0), ms_e3(r.itow_ms), fx(r.lon_e7 * 100 + r.lon_hp, 9),
        fx(r.lat_e7 * 100 + r.lat_hp, 9), fx(r.height_mm * 10 + r.height_hp_01mm, 4),
        fx(r.hmsl_mm * 10 + r.hmsl_hp_01mm, 4), fx(r.h_acc_01mm, 4), fx(r.v_acc_01mm, 4))


def kn_mps(v_e3):
    # knots*1000 -> m/s printed to 0.1 mm/s, rounded with integers only
    if v_e3 is None:
        return "null"
    return fx((v_e3 * 18520 + 18000) // 36000, 4)


def kmh_mps(v_e3):
    if v_e3 is None:
        return "null"
    return fx((v_e3 * 10 + 18) // 36, 4)


def msg_json(gp, kind):
    name = gnss.KIND_NAMES[kind]
    if kind == gnss.K_NAV_PVT:
        body = nav_pvt(gp.pvt)
    elif kind == gnss.K_NAV_RELPOSNED:
        body = nav_relposned(gp.relpos)
    elif kind == gnss.K_NAV_HPPOSLLH:
        body = nav_hpposllh(gp.hppos)
    elif kind == gnss.K_NAV_EOE:
        body = '"iTOW":%s' % ms_e3(gp.eoe.itow_ms)
    elif kind == gnss.K_ACK_ACK or kind == gnss.K_ACK_NAK:
        body = '"clsID":%d,"msgID":%d' % (gp.ack.cls, gp.ack.id)
    elif kind == gnss.K_GGA:
        r = gp.gga
        body = ('"talker":%s,"time":%s,"lat":%s,"lon":%s,"quality":%s,"numSV":%s,"HDOP":%s,'
                '"alt":%s,"sep":%s,"diffAge":%s,"diffStation":%s') % (
            talker(r.talker), ms_e3(r.utc_ms), fx(r.lat_e7, 7), fx(r.lon_e7, 7),
            fx(r.quality, 0), fx(r.num_sv, 0), fx(r.hdop_e3, 3), fx(r.alt_mm, 3),
            fx(r.sep_mm, 3), fx(r.diff_age_e3, 3), fx(r.diff_station, 0))
    elif kind == gnss.K_RMC:
        r = gp.rmc
        body = ('"talker":%s,"time":%s,"status":%s,"lat":%s,"lon":%s,"spd_kn":%s,"sog":%s,'
                '"cog":%s,"date":%s,"mv":%s,"mvEW":%s,"posMode":%s') % (
            talker(r.talker), ms_e3(r.utc_ms), qs(r.status), fx(r.lat_e7, 7), fx(r.lon_e7, 7),
            fx(r.sog_kn_e3, 3), kn_mps(r.sog_kn_e3), fx(r.cog_e3, 3),
            '"%06d"' % r.date if r.date is not None else "null", fx(r.magvar_e3, 3),
            qs(r.magvar_dir), qs(r.pos_mode))
    elif kind == gnss.K_VTG:
        r = gp.vtg
        sog = kmh_mps(r.sog_kmh_e3) if r.sog_kmh_e3 is not None else kn_mps(r.sog_kn_e3)
        body = ('"talker":%s,"cogt":%s,"cogm":%s,"sogn_kn":%s,"sogk_kmh":%s,"sog":%s,'
                '"posMode":%s') % (
            talker(r.talker), fx(r.cog_t_e3, 3), fx(r.cog_m_e3, 3), fx(r.sog_kn_e3, 3),
            fx(r.sog_kmh_e3, 3), sog, qs(r.pos_mode))
    elif kind == gnss.K_GST:
        r = gp.gst
        body = ('"talker":%s,"time":%s,"rangeRms":%s,"stdMajor":%s,"stdMinor":%s,"orient":%s,'
                '"stdLat":%s,"stdLong":%s,"stdAlt":%s') % (
            talker(r.talker), ms_e3(r.utc_ms), fx(r.rms_e3, 3), fx(r.major_e3, 3),
            fx(r.minor_e3, 3), fx(r.orient_e3, 3), fx(r.sd_lat_e3, 3), fx(r.sd_lon_e3, 3),
            fx(r.sd_alt_e3, 3))
    elif kind == gnss.K_HDT:
        body = '"talker":%s,"heading":%s' % (talker(gp.hdt.talker), fx(gp.hdt.heading_e3, 3))
    elif kind == gnss.K_THS:
        r = gp.ths
        body = '"talker":%s,"headt":%s,"mi":%s' % (talker(r.talker), fx(r.heading_e3, 3),
                                                   qs(r.mode))
    elif kind == gnss.K_RTCM3:
        body = '"msgType":%d,"length":%d' % (gp.rtcm.msg_type, gp.rtcm.length)
    elif kind == gnss.K_UBX_OTHER:
        o = gp.other
        name = "UBX-%02X-%02X" % (o.cls, o.id)
        body = '"length":%d' % o.length
    else:
        f = gp.other.formatter
        name = "%s%s%s" % (chr((f >> 16) & 255), chr((f >> 8) & 255), chr(f & 255)) if f \
            else "NMEA"
        body = '"talker":%s' % talker(gp.fields.talker())
    return '{"type":"%s",%s}' % (name, body)


def fix_json(f):
    return ('{"type":"FIX","t_ms":%d,"itow":%s,"utc_s":%d,"date":%d,"pos_valid":%s,'
            '"lat":%s,"lon":%s,"height":%s,"rtk":"%s","num_sv":%d,"h_acc":%.4f,'
            '"heading_valid":%s,"heading":%.5f,"heading_acc":%.5f,"vel_valid":%s,"sog":%.4f,'
            '"cog":%.3f,"sources":"%s"}') % (
        f.t_ms, ms_e3(f.itow_ms) if f.itow_ms >= 0 else "null", f.utc_s, f.date,
        "true" if f.pos_valid else "false", fx(f.lat_e7 * 100 + f.lat_hp, 9),
        fx(f.lon_e7 * 100 + f.lon_hp, 9), fx(f.height_mm, 3), RTK_NAMES[f.rtk], f.num_sv,
        f.h_acc_m, "true" if f.heading_valid else "false", f.heading_deg, f.heading_acc_deg,
        "true" if f.vel_valid else "false", f.sog_mps, f.cog_deg,
        "+".join(gnss.KIND_NAMES[k] for k in range(1, 16) if f.sources & (1 << k)))


def stats_json(st):
    names = ("bytes", "ubx_ok", "nmea_ok", "rtcm_ok", "ck_err", "broken", "oversize", "dropped",
             "unknown", "bad_field", "garbage", "comments", "epochs", "late")
    return "{%s}" % ",".join('"%s":%d' % (k, getattr(st, k)) for k in names)


def main(argv):
    path = None
    fixes = False
    chunk = 64
    offset = 0.0
    i = 1
    while i < len(argv):
        a = argv[i]
        if a == "--fixes":
            fixes = True
        elif a == "--chunk":
            i += 1
            chunk = int(argv[i])
        elif a == "--offset":
            i += 1
            offset = float(argv[i])
        else:
            path = a
        i += 1
    if path is None:
        print("usage: gnss_decode.py FILE [--fixes] [--chunk N] [--offset DEG]")
        sys.exit(2)
    fix = Fix()
    gp = gnss.GnssParser(fix, heading_offset_deg=offset, skip_comments=True,
                         epoch_timeout_ms=0)
    if not fixes:
        gp.on_msg = lambda kind: print(msg_json(gp, kind))
    else:
        gp.on_epoch = lambda: print(fix_json(fix))
    buf = bytearray(chunk)
    with open(path, "rb") as fh:
        while True:
            n = fh.readinto(buf)
            if not n:
                break
            gp.feed(buf, n, 0)
    gp.flush(0)  # the stream ended: close the last epoch
    sys.stderr.write(stats_json(gp.stats) + "\n")


main(sys.argv)
