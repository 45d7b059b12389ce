"""The web monitor: in a real headless browser (Debian's chromium) against a running simulator,
the page shows the boat on the track and updates; a second boat appears under its own id; the
server is read-only. Skips only where chromium is not installed (.ci/run installs it)."""
import json
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from html.parser import HTMLParser

import pytest

from trackpilot_tools.mpy import ROOT

sys.path.insert(0, str(ROOT / "hmi"))
sys.path.insert(0, str(ROOT / "firmware"))

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
TRACK = str(ROOT / "tracks" / "middelburg_loop.csv")


def _free_port(kind=socket.SOCK_DGRAM):
    s = socket.socket(socket.AF_INET, kind)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


class _Boats(HTMLParser):
    """The boat cards (div.boat with data-*) and the map canvas' data-boats-drawn of a DOM dump."""

    def __init__(self):
        super().__init__()
        self.boats = {}
        self.drawn = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "div" and "boat" in (a.get("class") or "").split():
            self.boats[int(a["data-id"])] = a
        if tag == "canvas" and a.get("id") == "map":
            self.drawn = a.get("data-boats-drawn")


def _browser_dom(url):
    with tempfile.TemporaryDirectory() as profile:
        r = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                            "--no-first-run", "--disable-background-networking", "--disable-component-update",
                            "--disable-sync", "--user-data-dir=" + profile, "--virtual-time-budget=2500",
                            "--dump-dom", url], capture_output=True, text=True, timeout=90)
    p = _Boats()
    p.feed(r.stdout)
    return p


def _get(url, method="GET"):
    req = urllib.request.Request(url, method=method)
    try:
        with urllib.request.urlopen(req, timeout=5) as f:
            return f.status, f.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (apt-get install -y chromium; .ci/run does)")
def test_page_shows_the_boat_and_updates(tmp_path):
    from tphmi.samples import sample
    from tphmi.status import encode_status

    udp, http = _free_port(), _free_port(socket.SOCK_STREAM)
    base = "http://127.0.0.1:%d/" % http
    mon = subprocess.Popen([sys.executable, "-m", "trackpilot_tools.cli", "monitor", "--web", "--udp", str(udp),
                            "--http-port", str(http), "--track", TRACK, "--duration", "90"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(ROOT))
    sim = subprocess.Popen([sys.executable, "-m", "trackpilot_tools.cli", "sim", TRACK, "--out", str(tmp_path / "sim"),
                            "--realtime", "--realtime-speed", "3", "--duration-s", "240", "--no-plots",
                            "--udp-port", str(udp), "--nmea-port", str(_free_port()), "--fw-set", "hmi.boat_id=7"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=str(ROOT))
    try:
        t_end = time.monotonic() + 40
        state = None
        while time.monotonic() < t_end:  # until the simulated boat is engaged and moving
            try:
                state = json.loads(_get(base + "api/state")[1])
                if any(b["id"] == 7 and b["mode_text"].startswith("AUTO") for b in state["boats"]):
                    break
            except OSError:
                pass
            time.sleep(0.5)
        assert state and state["track"][0]["name"] == "quay_start", state
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # a second boat, id 3
        st = sample("auto_right")
        st.boat_id, st.seq = 3, 100
        tx.sendto(encode_status(st), ("127.0.0.1", udp))

        first = _browser_dom(base)
        time.sleep(2.0)
        second = _browser_dom(base)
        assert 7 in first.boats and 3 in first.boats, first.boats
        b1, b2 = first.boats[7], second.boats[7]
        assert b1["data-mode"].startswith("AUTO") and b1["data-stale"] == "false"
        assert int(b2["data-seq"]) > int(b1["data-seq"]), (b1, b2)  # the page updates
        e1, n1, e2, n2 = (float(b[k]) for b in (b1, b2) for k in ("data-e", "data-n"))
        assert 0 < abs(e2 - e1) + abs(n2 - n1) < 100  # it moves, in local metres near the track
        assert abs(e1) < 800 and abs(n1) < 500
        assert int(first.drawn) == 2  # both boats drawn on the map

        code, _ = _get(base + "api/state", "POST")
        assert code == 405  # read-only
        assert _get(base + "monitor.js")[0] == 200
    finally:
        sim.terminate()
        sim.wait(timeout=30)
        mon.terminate()
        mon.wait(timeout=10)


def test_book_counts_lost_datagrams_hides_cleared_alarm_and_marks_ack():
    from tphmi.samples import sample
    from tphmi.status import encode_status

    from trackpilot_tools.webmon import Book

    book = Book(track=[("a", 514900000, 36100000), ("b", 514910000, 36100000)])
    st = sample("auto_right")
    st.boat_id, st.alarms, st.sounding, st.alarm_reason = 2, 2 | 8, 8, "gnss: RTK lost"
    for seq, now in ((10, 1.0), (11, 2.0), (14, 3.0)):
        st.seq = seq
        book.datagram(encode_status(st), now)
    assert book.datagram(b"TPS\x01junk", 3.5) is None and book.bad == 1
    boat = book.to_json()["boats"][0]
    assert boat["id"] == 2 and boat["lost"] == 2 and boat["count"] == 3
    acks = {a["name"]: a["ack"] for a in boat["alarms"]}
    assert len(acks) == 2 and sorted(acks.values()) == [False, True]
    assert boat["alarm_reason"] == "gnss: RTK lost"
    st.alarms = st.sounding = 0  # cleared: the reason text stays in the status but is not shown
    st.seq = 15
    book.datagram(encode_status(st), 4.0)
    boat = book.to_json()["boats"][0]
    assert boat["alarms"] == [] and boat["alarm_reason"] == ""
    assert len(boat["history"]["t"]) == 4


def test_web_view_from_the_usb_console(tmp_path):
    """`--web --serial PORT`: `TPS <hex>` lines among other console output, on a pseudo-terminal."""
    import binascii
    import os
    import tty

    from tphmi.samples import sample
    from tphmi.status import encode_status

    master, slave = os.openpty()
    tty.setraw(slave)
    http = _free_port(socket.SOCK_STREAM)
    mon = subprocess.Popen([sys.executable, "-m", "trackpilot_tools.cli", "monitor", "--web", "--serial",
                            os.ttyname(slave), "--http-port", str(http), "--duration", "30"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(ROOT))
    try:
        assert "web monitor: http://localhost:%d/" % http in mon.stdout.readline()
        st = sample("auto_left_far")
        st.boat_id = 5
        for seq in range(3):
            st.seq = seq
            os.write(master, b"I (123) boot: noise on the console\r\n")
            os.write(master, b"TPS " + binascii.hexlify(encode_status(st)) + b"\r\n")
            time.sleep(0.2)
        t_end = time.monotonic() + 10
        while time.monotonic() < t_end:
            state = json.loads(_get("http://127.0.0.1:%d/api/state" % http)[1])
            if state["datagrams"] >= 3:
                break
            time.sleep(0.2)
        assert state["source"].startswith("serial:") and state["datagrams"] == 3 and state["bad"] == 0
        (boat,) = state["boats"]
        assert boat["id"] == 5 and boat["seq"] == 2 and boat["lost"] == 0
        assert boat["xte_m"] == round(st.xte_m, 2)
    finally:
        mon.terminate()
        mon.wait(timeout=10)
        os.close(master)
        os.close(slave)
