"""The simulated receiver's own UBX encoders (independent of the firmware's parser; verified against
pyubx2 in tests/host/test_sim_encoders.py). Layouts: u-blox ZED-F9P interface description."""
import struct

_PVT = struct.Struct("<IHBBBBBBIiBBBBiiiiIIiiiiiIIHH4xihH")  # 92 bytes
_HPPOSLLH = struct.Struct("<B2xBIiiiibbbbII")  # 36 bytes
_RELPOSNED = struct.Struct("<BBHIiiiii4xbbbbIIIII4xI")  # 64 bytes


def frame(cls, mid, payload):
    body = bytes((cls, mid)) + struct.pack("<H", len(payload)) + payload
    a = b = 0
    for x in body:
        a = (a + x) & 0xFF
        b = (b + a) & 0xFF
    return b"\xb5\x62" + body + bytes((a, b))


def split_hp(value, unit):
    """A value in `unit`s -> (coarse in 100 units, fine in units, |fine| <= 99), truncating
    toward zero as u-blox does for RELPOSNED (cm + 0.1 mm)."""
    total = int(round(value / unit))
    coarse = int(total / 100)
    return coarse, total - coarse * 100


def nav_pvt(itow_ms, utc, fix_type, flags, num_sv, lon_e7, lat_e7, height_mm, hmsl_mm, h_acc_mm,
            v_acc_mm, vel_n_mms, vel_e_mms, vel_d_mms, g_speed_mms, head_mot_e5, s_acc_mms,
            head_acc_e5, pdop_e2=120, head_veh_e5=0, valid=0x07, flags2=0xE0):
    """utc: (year, month, day, hour, minute, second, nano)."""
    year, month, day, hour, minute, second, nano = utc
    payload = _PVT.pack(itow_ms, year, month, day, hour, minute, second, valid, 20, nano,
                        fix_type, flags, flags2, num_sv, lon_e7, lat_e7, height_mm, hmsl_mm,
                        h_acc_mm, v_acc_mm, vel_n_mms, vel_e_mms, vel_d_mms, g_speed_mms,
                        head_mot_e5, s_acc_mms, head_acc_e5, pdop_e2, 0, head_veh_e5, 0, 0)
    return frame(0x01, 0x07, payload)


def nav_hpposllh(itow_ms, lon_e7, lat_e7, lon_hp, lat_hp, height_mm, hmsl_mm, height_hp=0,
                 hmsl_hp=0, h_acc_01mm=140, v_acc_01mm=200, invalid=False):
    payload = _HPPOSLLH.pack(0, 1 if invalid else 0, itow_ms, lon_e7, lat_e7, height_mm, hmsl_mm,
                             lon_hp, lat_hp, height_hp, hmsl_hp, h_acc_01mm, v_acc_01mm)
    return frame(0x01, 0x14, payload)


# NAV-RELPOSNED flags
RP_GNSS_FIX_OK = 1 << 0
RP_DIFF_SOLN = 1 << 1
RP_REL_POS_VALID = 1 << 2
RP_CARR_FLOAT = 1 << 3
RP_CARR_FIXED = 2 << 3
RP_IS_MOVING = 1 << 5
RP_HEADING_VALID = 1 << 8


def nav_relposned(itow_ms, n_m, e_m, d_m, length_m, heading_e5, acc_n_01mm, acc_e_01mm,
                  acc_d_01mm, acc_len_01mm, acc_heading_e5, flags):
    n, nhp = split_hp(n_m, 1e-4)
    e, ehp = split_hp(e_m, 1e-4)
    d, dhp = split_hp(d_m, 1e-4)
    ln, lhp = split_hp(length_m, 1e-4)
    payload = _RELPOSNED.pack(1, 0, 0, itow_ms, n, e, d, ln, heading_e5, nhp, ehp, dhp, lhp,
                              acc_n_01mm, acc_e_01mm, acc_d_01mm, acc_len_01mm, acc_heading_e5, flags)
    return frame(0x01, 0x3C, payload)
