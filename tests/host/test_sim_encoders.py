"""The simulated receiver's and wind sensor's own encoders, checked against pyubx2 / pynmeagps."""
import io
import math
import sys
from pathlib import Path

import pytest
from pyubx2 import UBXReader
from pynmeagps import NMEAReader

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "host_tools"))
from trackpilot_tools.sim import f9p, geodesy, nmea_enc, params, randproc  # noqa: E402


def _epoch(nmea=True, heading=33.0, fault=None, seed=3):
    p = params.load()["gnss"]
    p["nmea"] = nmea
    p["antenna_fwd_m"] = 1.5
    p["antenna_stbd_m"] = -0.4
    frame = geodesy.LocalFrame(51.49, 3.61)
    rx = f9p.F9P(p, randproc.component_rng(seed, "gnss"), frame)
    if fault:
        rx.set_fault(fault, True, 0)
    truth = {"east_m": 310.0, "north_m": -120.0, "heading_grid_deg": heading, "vel_e": 1.2, "vel_n": -0.7}
    return p, frame, rx, truth, rx.epoch(400, truth)


def _parse(data):
    return [m for _, m in UBXReader(io.BytesIO(data), protfilter=3)]


def test_epoch_order_and_fields_match_pyubx2():
    p, frame, rx, truth, (t_out, data) = _epoch()
    msgs = _parse(data)
    names = [m.identity for m in msgs]
    assert names == ["GNGGA", "GNRMC", "NAV-RELPOSNED", "NAV-HPPOSLLH", "NAV-PVT"]  # NAV-PVT last
    assert 400 + 50 <= t_out <= 400 + 100 + 40  # latency 50-100 ms + transmission
    gga, rmc, rel, hp, pvt = msgs
    # the antenna position: reference point + lever arm along the heading, within RTK noise
    h = math.radians(truth["heading_grid_deg"])
    e = truth["east_m"] + 1.5 * math.sin(h) - 0.4 * math.cos(h)
    n = truth["north_m"] + 1.5 * math.cos(h) + 0.4 * math.sin(h)
    lat, lon, conv = frame.to_latlon(e, n)
    pe, pn = frame.from_latlon(hp.lat, hp.lon)
    assert math.hypot(pe - e, pn - n) < 0.08  # fixed RTK: a few cm
    assert abs(pvt.lat - hp.lat) < 1.5e-7 and abs(pvt.lon - hp.lon) < 1.5e-7
    assert abs(gga.lat - hp.lat) < 2e-9 and abs(gga.lon - hp.lon) < 2e-9  # same fix, 7-decimal minutes
    assert gga.quality == 4 and rmc.posMode == "R"
    assert pvt.carrSoln == 2 and pvt.fixType == 3 and pvt.gnssFixOk == 1
    assert rel.version == 1 and rel.relPosHeadingValid == 1 and rel.carrSoln == 2
    assert abs(((rel.relPosHeading - (33.0 + conv)) + 180) % 360 - 180) < 1.5
    assert abs(math.degrees(math.atan2(rel.relPosE, rel.relPosN)) - rel.relPosHeading) < 0.05
    assert abs(pvt.gSpeed / 1000.0 - math.hypot(1.2, -0.7)) < 0.2
    assert abs(pvt.velE / 1000.0 - 1.2) < 0.2 and abs(pvt.velN / 1000.0 + 0.7) < 0.2
    assert pvt.iTOW == hp.iTOW == rel.iTOW


@pytest.mark.parametrize("fault,carr,quality", [("float", 1, 5), ("single", 0, 1)])
def test_float_and_single(fault, carr, quality):
    _, _, rx, _, (_, data) = _epoch(fault=fault)
    gga, rmc, rel, hp, pvt = _parse(data)
    assert pvt.carrSoln == carr and gga.quality == quality
    assert pvt.hAcc > 100  # mm
    if fault == "single":
        assert rel.relPosHeadingValid == 0


def test_heading_loss_and_dropout():
    _, _, rx, _, (_, data) = _epoch(fault="heading_loss")
    rel = _parse(data)[2]
    assert rel.relPosHeadingValid == 0
    _, _, rx, truth, got = _epoch(fault="dropout")
    assert got is None
    rx.set_fault("dropout", False, 400)
    _, data = rx.epoch(600, truth)
    assert _parse(data)[4].carrSoln == 0  # comes back single first
    _, data = rx.epoch(400 + 2000 + 200, truth)
    assert _parse(data)[4].carrSoln == 1  # then float
    _, data = rx.epoch(400 + 10000 + 200, truth)
    assert _parse(data)[4].carrSoln == 2


def test_hp_split_and_ddmm_exact():
    for deg in (51.4901799133, -3.6101439933, 0.000000049, 179.999999999):
        e7, hp = geodesy.deg_to_e7_hp(deg)
        assert -50 <= hp <= 50 and abs(geodesy.e7_hp_to_deg(e7, hp) - deg) < 1e-9
    txt, hemi = nmea_enc.ddmm(514901799, 33, True)
    assert (txt, hemi) == ("5129.4107960", "N")  # 0.4901799330 deg = 29.410795980 min


def test_mwv_against_pynmeagps():
    data = nmea_enc.mwv(287.25, 5.44)
    msg = NMEAReader.parse(data.decode())
    assert msg.msgID == "MWV" and msg.reference == "R" and msg.status == "A"
    assert msg.angle == pytest.approx(287.2, abs=0.06) and msg.speed == pytest.approx(5.4) and msg.speedu == "M"
