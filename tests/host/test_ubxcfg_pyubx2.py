"""The receiver configuration bytes (firmware ubxcfg, run under MicroPython) equal pyubx2's
encoder (`UBXMessage.config_set`), and every key id equals pyubx2's configuration database."""
import json

import pytest
from pyubx2 import SET, UBXMessage, UBXReader
from pyubx2.ubxtypes_configdb import UBX_CONFIG_DATABASE

from trackpilot_tools.mpy import FIRMWARE_DIR, ROOT, run_script

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

SCRIPT = r'''
import sys
from trackpilot.devices import ubxcfg
cases = [
    (ubxcfg.rover_items(), 1),
    (ubxcfg.rover_items(rate_ms=100, nmea=(), eoe=False, hppos=False, baudrate=115200,
                        rtcm_in=False), 1 | 2 | 4),
    (ubxcfg.rover_items(nmea=("GGA", "RMC", "GST", "THS")), 2),
]
for items, layers in cases:
    frames = ubxcfg.valset_frames(items, layers)
    print('{"items":[%s],"layers":%d,"frames":[%s]}' % (
        ",".join('["%s",%d]' % (k, v) for k, v in items), layers,
        ",".join('"%s"' % "".join("%02x" % b for b in f) for f in frames)))
print('{"keys":{%s}}' % ",".join('"%s":%d' % (k, v) for k, v in ubxcfg.KEYS.items()))
'''


def _run(tmp_path):
    script = tmp_path / "cfg.py"
    script.write_text(SCRIPT)
    out = run_script(script).stdout.decode()
    return [json.loads(line) for line in out.splitlines()]


def test_valset_bytes_equal_pyubx2(tmp_path):
    lines = _run(tmp_path)
    keys = lines[-1]["keys"]
    for name, kid in keys.items():
        assert UBX_CONFIG_DATABASE[name.replace("-", "_")][0] == kid, name
    n = 0
    for case in lines[:-1]:
        items = [(k.replace("-", "_"), v) for k, v in case["items"]]
        ref = UBXMessage.config_set(case["layers"], 0, items).serialize()
        assert len(case["frames"]) == 1
        assert bytes.fromhex(case["frames"][0]) == ref
        parsed = UBXReader.parse(bytes.fromhex(case["frames"][0]), msgmode=SET)
        assert parsed.identity == "CFG-VALSET"
        n += 1
    print("VALSET frames equal to pyubx2: %d (keys checked: %d)" % (n, len(keys)))
    assert n == 3


def test_rover_config_content(tmp_path):
    case = _run(tmp_path)[0]
    items = dict(case["items"])
    assert items["CFG-RATE-MEAS"] == 200  # 5 Hz
    for msg in ("PVT", "RELPOSNED", "HPPOSLLH", "EOE"):
        assert items["CFG-MSGOUT-UBX_NAV_%s_UART1" % msg] == 1
    assert items["CFG-MSGOUT-NMEA_ID_GGA_UART1"] == 1
    assert items["CFG-MSGOUT-NMEA_ID_GSV_UART1"] == 0
