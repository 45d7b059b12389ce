# Wi-Fi (trackpilot/wifi.py) with a fake `network` module: connect, timeout and back-off, loss and
# reconnect, the access point only with WPA2, the password never in an event; the state in the
# status datagram.
import tpassert as t
from trackpilot import config, wifi

SECRET = "hunter2-secret"
AP_SECRET = "ap-secret-123"


class FakeWlan:
    def __init__(self, net, kind):
        self.net = net
        self.kind = kind
        self.is_active = False
        self.connected = False
        self.connects = []
        self.conf = {}

    def active(self, on=None):
        if on is not None:
            self.is_active = on
        return self.is_active

    def connect(self, ssid, password):
        if self.net.fail_connect:
            raise OSError("Wifi Internal Error for " + password)  # an error could echo it
        self.connects.append((ssid, password))

    def disconnect(self):
        self.connected = False

    def isconnected(self):
        return self.connected

    def status(self):
        return 201 if not self.connected else 1010

    def ifconfig(self):
        return ("192.168.8.20", "255.255.255.0", "192.168.8.1", "192.168.8.1")

    def config(self, **kw):
        self.conf.update(kw)


class FakeNetwork:
    STA_IF = 0
    AP_IF = 1
    AUTH_WPA2_PSK = 3

    def __init__(self):
        self.fail_connect = False
        self.ifs = {}

    def WLAN(self, kind):
        if kind not in self.ifs:
            self.ifs[kind] = FakeWlan(self, kind)
        return self.ifs[kind]


def _cfg(**kw):
    c = dict(config.defaults()["wifi"])
    c.update(enabled=True, ssid="boat-4g", password=SECRET)
    c.update(kw)
    return c


def _no_secret(events):
    for e in events:
        t.true(SECRET not in e and AP_SECRET not in e, e)


def test_connects_and_reports_up():
    net = FakeNetwork()
    link = wifi.WifiLink(_cfg(), net)
    ev = list(link.start(0))
    t.eq(link.state, wifi.CONNECTING)
    t.eq(net.ifs[0].connects, [("boat-4g", SECRET)])
    t.eq(net.ifs[1].is_active, False)  # no access point unless asked for
    net.ifs[0].connected = True
    ev += link.poll(500)
    t.true(link.is_up() and link.ip == "192.168.8.20", ev)
    t.true("up: 'boat-4g', address 192.168.8.20" in ev[-1], ev)
    t.eq(list(link.start(600)), [])  # an app restart keeps the link
    _no_secret(ev)


def test_timeout_backoff_doubles_to_the_limit_and_resets():
    net = FakeNetwork()
    link = wifi.WifiLink(_cfg(connect_timeout_ms=10000, backoff_min_ms=2000, backoff_max_ms=6000), net)
    ev = list(link.start(0))
    retries = []
    t_ms = 0
    while t_ms < 80000:
        t_ms += 500
        for e in link.poll(t_ms):
            ev.append(e)
            if "retry in" in e:
                retries.append((t_ms, e.split("retry in ")[1]))
    t.eq([r[1] for r in retries[:4]], ["2 s", "4 s", "6 s", "6 s"])
    t.eq(retries[0][0], 10000)  # the attempt times out after connect_timeout_ms
    t.eq(link.state in (wifi.CONNECTING, wifi.RETRY), True)
    net.ifs[0].connected = True
    while not link.is_up():
        t_ms += 500
        ev += link.poll(t_ms)
    t.eq(link.backoff_ms, 2000)  # back to the start once up
    _no_secret(ev)


def test_lost_link_reconnects():
    net = FakeNetwork()
    link = wifi.WifiLink(_cfg(), net)
    link.start(0)
    net.ifs[0].connected = True
    link.poll(500)
    net.ifs[0].connected = False
    ev = link.poll(1000)
    t.true(ev[0].startswith("lost 'boat-4g'") and ev[1].startswith("connecting"), ev)
    t.eq(link.state, wifi.CONNECTING)
    t.eq(len(net.ifs[0].connects), 2)


def test_connect_error_does_not_leak_the_password():
    net = FakeNetwork()
    net.fail_connect = True
    link = wifi.WifiLink(_cfg(), net)
    ev = list(link.start(0))
    t.eq(link.state, wifi.RETRY)
    t.true("connect to 'boat-4g' failed: OSError; retry in 2 s" in ev[-1], ev)
    _no_secret(ev)


def test_access_point_only_with_wpa2_password():
    net = FakeNetwork()
    link = wifi.WifiLink(_cfg(enabled=False, ap_enabled=True, ap_password="short"), net)
    ev = list(link.start(0))
    t.true(not link.ap_active and not net.ifs[1].is_active and "no open access point" in ev[0], ev)
    net = FakeNetwork()
    link = wifi.WifiLink(_cfg(enabled=False, ap_enabled=True, ap_password=AP_SECRET), net)
    ev = list(link.start(0))
    t.true(link.ap_active and net.ifs[1].is_active, ev)
    t.eq(net.ifs[1].conf, {"essid": "trackpilot", "password": AP_SECRET, "authmode": 3})
    t.eq(link.state, wifi.OFF)  # no station asked for
    t.eq(0 in net.ifs, False)
    _no_secret(ev)


def test_config_section_and_status_datagram():
    cfg = config.defaults()
    t.eq(cfg["wifi"]["enabled"], False)
    cfg["wifi"]["ssid"] = "boat-4g"
    t.eq(config.validate(cfg), [])
    cfg["wifi"]["password"] = 31415926
    cfg["wifi"]["ap_password"] = 27182818
    errors = config.validate(cfg)
    t.eq(len(errors), 2)
    t.true(not any("31415926" in e or "27182818" in e for e in errors), errors)  # secrets
    cfg["wifi"]["password"] = cfg["wifi"]["ap_password"] = ""
    try:
        from tphmi.status import HmiStatus, decode_status, encode_status
    except ImportError:
        return
    st = HmiStatus()
    st.pilot_ok = True
    st.wifi = wifi.RETRY
    st.wifi_ap = True
    back = decode_status(encode_status(st))
    t.eq((back.wifi, back.wifi_ap, back.pilot_ok), (3, True, True))
    st.wifi = 0
    st.wifi_ap = False
    back = decode_status(encode_status(st))
    t.eq((back.wifi, back.wifi_ap, back.pilot_ok), (0, False, True))


def test_app_starts_ntrip_once_the_link_is_up():
    try:
        import asyncio
    except ImportError:
        print("skipped: no asyncio")
        return
    from test_app_track_load import _app

    app, w = _app()
    app.cfg["ntrip"]["enabled"] = True
    net = FakeNetwork()
    w.wifi = wifi.WifiLink(_cfg(), net)
    started = []

    class _Task:
        def done(self):
            return False

    def fake_start():
        started.append(w.t)
        app.ntrip_task = _Task()

    app.ntrip_task = None
    app.start_ntrip = fake_start

    async def scenario():
        task = asyncio.create_task(app.task_wifi())
        await asyncio.sleep_ms(700)  # two polls: connecting, no NTRIP yet
        t.eq(started, [])
        w.t = 3000
        net.ifs[0].connected = True
        await asyncio.sleep_ms(600)
        task.cancel()

    asyncio.run(scenario())
    t.true(started and started[0] == 3000, started)
    wifi_lines = [x for x in w.lines if x.startswith("WIFI")]
    t.true("connecting to 'boat-4g'" in wifi_lines[0] and "up: 'boat-4g'" in wifi_lines[-1], wifi_lines)
    _no_secret(w.lines)
