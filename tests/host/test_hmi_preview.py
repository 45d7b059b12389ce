"""`trackpilot hmi preview` and the HMI's CPython-side interop (status datagram, command HMAC)."""
import hmac
import hashlib
import json
import struct
import sys
from pathlib import Path

import pytest
from PIL import Image

from trackpilot_tools import hmi_cmd
from trackpilot_tools.cli import main
from trackpilot_tools.mpy import FIRMWARE_DIR, HMI_DIR, run_script

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

for _p in (str(FIRMWARE_DIR), str(HMI_DIR)):
    if _p not in sys.path:
        sys.path.insert(0, _p)

PAGES = ("main", "gnss", "pilot", "alarms", "link_lost")


def _lit(img, box):
    """Number of lit pixels of a 4x PNG within a box given in display pixels."""
    x0, y0, x1, y1 = box
    return sum(1 for v in img.crop((4 * x0, 4 * y0, 4 * x1, 4 * y1)).tobytes() if v) // 16


def test_preview_default_writes_every_page(tmp_path):
    assert main(["hmi", "preview", "--out", str(tmp_path)]) == 0
    for name in PAGES:
        img = Image.open(tmp_path / ("hmi_%s.png" % name))
        assert img.size == (512, 256)
        assert _lit(img, (0, 0, 128, 9)) > 100, "header drawn on %s" % name
        assert _lit(img, (0, 10, 128, 64)) > 200, "content drawn on %s" % name


def test_preview_status_json_bar_direction(tmp_path):
    lit = {}
    for xte in (6.0, -6.0):
        f = tmp_path / ("st%d.json" % xte)
        f.write_text(json.dumps({"mode": 1, "nav_valid": True, "legs": 4, "xte_m": xte}))
        out = tmp_path / ("o%d" % xte)
        assert main(["hmi", "preview", "--status", str(f), "--out", str(out)]) == 0
        img = Image.open(out / "hmi_main.png")
        lit[xte] = (_lit(img, (2, 30, 62, 33)), _lit(img, (66, 30, 126, 33)))
    assert lit[6.0][1] > 50 and lit[6.0][0] == 0, lit
    assert lit[-6.0][0] > 50 and lit[-6.0][1] == 0, lit


def test_preview_rejects_unknown_field(tmp_path, capsys):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps({"xte": 1.0}))
    assert main(["hmi", "preview", "--status", str(f), "--out", str(tmp_path / "o")]) == 2
    assert "unknown status field" in capsys.readouterr().err


def test_preview_from_log(tmp_path):
    from trackpilot.record import logfmt

    enc = logfmt.LogEncoder()
    data = bytes(enc.header(fw_version="t", track_id="loop", reset_cause="power_on", t0_ms=0,
                            session=1, part=0))
    wps = [logfmt.LogWaypoint(514990000, 36100000, 1.5, "A", None),
           logfmt.LogWaypoint(515000000, 36100000, 1.5, "B", None),
           logfmt.LogWaypoint(515000000, 36120000, 1.5, "C", None)]
    data += bytes(enc.encode_track(wps, "loop"))
    for i in range(20):
        r = logfmt.ControlRecord()
        r.t_ms = i * 200
        r.pos_valid = r.heading_valid = True
        r.rtk = 3
        r.lat_e7, r.lon_e7 = 514995000 + i * 10, 36100200
        r.heading_deg = 1.0
        r.xte_m = -3.0
        r.mode = 1 if i >= 5 else 0
        r.pilot_mode = 1 if i >= 5 else 0
        r.rpm_set = 900
        data += bytes(enc.encode_control(r))
        if i == 2:
            data += bytes(enc.encode_event("REFUSED", "engage from HMI: no RTK fixed solution", r.t_ms))
    f = tmp_path / "0001-00.tpl"
    f.write_bytes(data)
    st = hmi_cmd.status_from_log([str(f)], at_s=0.6)
    assert st["mode"] == 0 and st["refusal"] == "no RTK fixed solution"
    st = hmi_cmd.status_from_log([str(f)])
    assert st["mode"] == 1 and st["legs"] == 2 and st["nav_valid"]
    assert 50 < st["to_wp_m"] < 57  # 4810e-7 deg (53.5 m) north to B
    out = tmp_path / "o"
    assert main(["hmi", "preview", "--log", str(f), "--out", str(out)]) == 0
    img = Image.open(out / "hmi_main.png")
    assert _lit(img, (2, 30, 62, 33)) > 10, "xte -3 m: bar to the left"


def test_refs_regenerate_identically(tmp_path):
    assert main(["hmi", "refs", "--out", str(tmp_path)]) == 0
    for s in hmi_cmd.REF_SAMPLES:
        name = "main_%s.pbm" % s
        assert (tmp_path / name).read_bytes() == (hmi_cmd.REF_DIR / name).read_bytes(), name


def test_status_datagram_same_bytes_on_cpython():
    """The host monitor decodes with the same module under CPython: bytes must agree."""
    from tphmi.preview.samples import sample
    from tphmi.status import decode_status, encode_status

    script = Path(__file__).parent / "_hmi_encode.py"
    script.write_text("import sys\nfrom tphmi.preview.samples import sample\nfrom tphmi.status import encode_status\n"
                      "print(''.join('%02x' % b for b in encode_status(sample(sys.argv[1]))))\n")
    try:
        for name in ("auto_right", "alarm_gnss", "standby_refused"):
            out = run_script(script, [name]).stdout.decode().strip()
            assert bytes.fromhex(out) == encode_status(sample(name))
            assert decode_status(bytes.fromhex(out)).to_dict()["alarm_reason"] == sample(name).alarm_reason
    finally:
        script.unlink()


def test_command_tag_is_standard_hmac_sha256():
    from tphmi.auth import CommandSigner, MemStore, init_state

    key = bytes(range(32))
    store = MemStore()
    init_state(store, key, 41)
    pkt = CommandSigner(key, 7, store).sign("NEXT_WP")
    assert pkt[:4] == b"TPC\x01"
    assert struct.unpack("<HIB", pkt[4:11]) == (7, 41, 3)
    assert pkt[11:] == hmac.new(key, pkt[:11], hashlib.sha256).digest()[:16]


def test_status_offsets_match_docs_telemetry():
    """A few offsets from docs/TELEMETRY.md, read straight from the bytes."""
    from tphmi.preview.samples import sample
    from tphmi.status import encode_status

    st = sample("alarm_gnss")
    b = encode_status(st)
    assert len(b) == 70 + len(st.alarm_reason.encode()) + len(st.refusal.encode()) + 6  # + trailer
    assert struct.unpack_from("<H", b, 4)[0] == st.boat_id
    assert b[8] == st.mode and b[11] == st.rtk
    assert struct.unpack_from("<ii", b, 26) == (st.lat_e7, st.lon_e7)
    assert struct.unpack_from("<i", b, 36)[0] == round(st.xte_m * 100)
    assert struct.unpack_from("<I", b, 64)[0] == st.cmd_counter
    assert b[68] == len(st.alarm_reason.encode())
    st.wind_angle_deg, st.wind_speed_mps, st.battery_v = 123.4, 5.67, 47.5
    b = encode_status(st)
    assert struct.unpack_from("<HHH", b, len(b) - 6) == (1234, 567, 4750)
    from tphmi.status import decode_status

    back = decode_status(b)
    assert (back.wind_angle_deg, back.wind_speed_mps, back.battery_v) == (123.4, 5.67, 47.5)
    old = decode_status(b[:-6])  # a datagram without the trailer still decodes
    assert old.wind_angle_deg == -1.0 and old.battery_v == -1.0
