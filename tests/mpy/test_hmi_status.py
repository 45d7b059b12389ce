# HmiStatus datagram: round trip, quantisation, and refusal of garbage.
import tpassert as T
from tphmi.status import HmiStatus, decode_status, encode_status, mode_text, alarm_names, TEXT_MAX


def _full():
    st = HmiStatus()
    st.update({"boat_id": 7, "seq": 65535, "mode": 1, "degraded": True, "estop_input": True,
               "alarms": 6, "sounding": 4, "alarm_reason": "RTK lost", "refusal": "no track",
               "cmd_counter": 4000000000, "rtk": 2, "pos_valid": True, "lat_e7": 514987654,
               "lon_e7": -36123456, "num_sv": 23, "h_acc_m": 0.014, "heading_valid": True,
               "heading_deg": 359.996, "heading_acc_deg": 0.3, "corr_age_s": 1.26, "sog_mps": 1.25,
               "nav_valid": True, "xte_m": -1.237, "leg": 2, "legs": 11, "to_wp_m": 187.4,
               "cmd_valid": True, "heading_cmd_deg": 125.6, "rpm_cmd": 1200, "rpm": -1,
               "pilot_ok": True, "pilot_mode": 2, "compass_deg": 131.0, "locked_deg": 133.0,
               "keystrokes": 412, "hang_recoveries": 3})
    return st


def test_round_trip():
    st = _full()
    d = decode_status(encode_status(st))
    for k in ("boat_id", "seq", "mode", "degraded", "estop_input", "alarms", "sounding", "alarm_reason",
              "refusal", "cmd_counter", "rtk", "pos_valid", "lat_e7", "lon_e7", "num_sv", "nav_valid",
              "leg", "legs", "rpm_cmd", "rpm", "pilot_ok", "pilot_mode", "keystrokes", "hang_recoveries",
              "heading_valid", "cmd_valid", "recovering", "holding"):
        T.eq(getattr(d, k), getattr(st, k), k)
    T.near(d.xte_m, -1.24, 0.001)
    T.near(d.heading_deg, 0.0, 0.001, "359.996 rounds to 0.00")
    T.near(d.h_acc_m, 0.01, 0.001)
    T.near(d.corr_age_s, 1.3, 0.001)
    T.near(d.to_wp_m, 187.4, 0.001)
    T.near(d.compass_deg, 131.0, 0.001)


def test_defaults_round_trip_and_unknown_corr_age():
    d = decode_status(encode_status(HmiStatus()))
    T.eq(d.corr_age_s, -1.0)
    T.eq(d.mode, 0)
    T.eq(d.refusal, "")


def test_clamps_out_of_range():
    st = _full()
    st.xte_m = 1e7
    st.rpm_cmd = 99999
    st.refusal = "x" * 200
    d = decode_status(encode_status(st))
    T.eq(d.rpm_cmd, 32767)
    T.eq(len(d.refusal), TEXT_MAX)
    T.true(d.xte_m > 1e6)


def test_garbage_refused():
    pkt = encode_status(_full())
    for bad in (b"", pkt[:10], pkt[:-1], pkt + b"x", b"XXXX" + pkt[4:], b"\x00" * len(pkt)):
        T.raises(ValueError, decode_status, bad)
    b = bytearray(pkt)
    b[len(encode_status(HmiStatus())) - 2] = 200  # alarm_reason length byte beyond TEXT_MAX
    T.raises(ValueError, decode_status, bytes(b))


def test_unknown_field_refused():
    T.raises(ValueError, HmiStatus().update, {"xte": 1.0})


def test_mode_text_and_alarm_names():
    st = HmiStatus()
    st.mode = 1
    T.eq(mode_text(st), "AUTO")
    st.recovering = True
    T.eq(mode_text(st), "AUTO recov")
    T.eq(alarm_names(2 | 256), ["gnss", "e-stop"])


def test_receiver_config_failure_travels_in_flags2():
    # issue 12: a failed CFG-VALSET session is shown (HMI GNSS page "CFG!"), beside the Wi-Fi bits
    st = _full()
    st.update({"gnss_cfg_failed": True, "wifi": 3, "wifi_ap": True})
    d = decode_status(encode_status(st))
    T.eq((d.gnss_cfg_failed, d.wifi, d.wifi_ap, d.pilot_ok), (True, 3, True, True))
    st.update({"gnss_cfg_failed": False})
    T.eq(decode_status(encode_status(st)).gnss_cfg_failed, False)


def test_pilot_hunting_travels_in_flags2():
    # issue 10: the pilot watch's "pilot hunts" (flags2 bit 5), beside the other bits
    st = _full()
    st.update({"pilot_hunts": True, "gnss_cfg_failed": True, "wifi": 2})
    d = decode_status(encode_status(st))
    T.eq((d.pilot_hunts, d.gnss_cfg_failed, d.wifi, d.pilot_ok), (True, True, 2, True))
    st.update({"pilot_hunts": False})
    T.eq(decode_status(encode_status(st)).pilot_hunts, False)
