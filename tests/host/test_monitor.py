"""The live monitor: decodes the firmware's status datagrams from UDP and shows a stale link."""
import socket
import subprocess
import sys
import time

import pytest
from trackpilot_tools.mpy import ROOT

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)

sys.path.insert(0, str(ROOT / "hmi"))
sys.path.insert(0, str(ROOT / "firmware"))


def _free_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def _monitor(args):
    return subprocess.Popen([sys.executable, "-m", "trackpilot_tools.cli", "monitor", "--plain"] + args,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(ROOT))


def test_monitor_shows_status_then_stale_link():
    from tphmi.samples import sample
    from tphmi.status import encode_status

    port = _free_port()
    mon = _monitor(["--udp", str(port), "--stale-s", "0.6", "--duration", "2.5"])
    assert "listening on udp:%d" % port in mon.stderr.readline()  # bound: nothing sent is lost
    st = sample("auto_right")
    st.wind_angle_deg, st.wind_speed_mps, st.battery_v = 45.0, 4.2, 48.1
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for seq in range(3):
        st.seq = seq
        tx.sendto(encode_status(st), ("127.0.0.1", port))
        time.sleep(0.05)
    tx.sendto(b"TPS\x01garbage", ("127.0.0.1", port))
    out, err = mon.communicate(timeout=10)
    assert "AUTO" in out and "link ok" in out, out
    assert "xte %+6.2f m" % st.xte_m in out
    assert "48.10 V" in out and "4.2 m/s" in out
    assert "LINK STALE" in out.splitlines()[-1], out
    assert "3 status datagrams, 1 bad" in err


def test_monitor_watches_a_simulated_run(tmp_path):
    port = _free_port()  # not the default 10111: other test runs may share this machine
    mon = _monitor(["--udp", str(port), "--count", "5", "--duration", "60"])
    assert "listening on" in mon.stderr.readline()
    sim = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "sim", str(ROOT / "tracks/middelburg_loop.csv"),
                          "--out", str(tmp_path / "out"), "--duration-s", "30", "--no-plots", "--udp-out",
                          "--udp-port", str(port), "--nmea-port", str(_free_port())],
                         capture_output=True, cwd=str(ROOT), timeout=120)
    assert sim.returncode == 0, sim.stderr.decode()[-2000:]
    out, err = mon.communicate(timeout=60)
    assert "5 status datagrams, 0 bad" in err, err
    assert "RTK" in out and "pilot" in out


def test_text_view_drops_a_cleared_alarm_and_marks_acknowledged():
    from tphmi.samples import sample

    from trackpilot_tools.monitor_cmd import render

    st = sample("auto_right")
    st.alarms, st.sounding, st.alarm_reason = 2 | 8, 8, "gnss: RTK lost"
    text = "\n".join(render(st, 0.1, 3.0, "udp"))
    assert "alarm   gnss: RTK lost" in text and "(ack)" in text
    st.alarms = st.sounding = 0  # cleared; the firmware keeps the last reason text in the status
    text = "\n".join(render(st, 0.1, 3.0, "udp"))
    assert "RTK lost" not in text and "alarms -" in text
