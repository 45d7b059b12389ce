"""Wi-Fi link: station mode with reconnect and back-off, an optional access point (functional core).

The boat's ESP32 joins the on-board router as a station (`wifi.ssid`, `wifi.password`): NTRIP
corrections, telemetry, NMEA to OpenCPN and the remote HMI box all need it. A connection attempt
that is not up within `connect_timeout_ms` is dropped and retried after a back-off that doubles
from `backoff_min_ms` to `backoff_max_ms` (reset once up); a lost link is retried at once, then
with the same back-off. Optionally an access point for a laptop on the water (`wifi.ap_enabled`,
`ap_ssid`, `ap_password`), WPA2 only: without a password of 8..63 characters it is not started
(there is never an open access point). Events name the network, never a password.

Fed a `network` module (the real one on the board, a fake in tests) and times; returns event texts.

Usage (wiring_esp32 builds it, the app polls it):
    link = WifiLink(cfg["wifi"], network)
    for text in link.start(t_ms): app.event("WIFI", text)
    for text in link.poll(t_ms): app.event("WIFI", text)    # every ~500 ms
    link.is_up(), link.state, NAMES[link.state], link.ip, link.ap_active
"""
from trackpilot.compat import const, ticks_add, ticks_diff

OFF = const(0)  # no station configured (or Wi-Fi disabled)
CONNECTING = const(1)
UP = const(2)
RETRY = const(3)  # waiting out the back-off before the next attempt
NAMES = ("off", "connecting", "up", "retry")

_AUTH_WPA2_PSK = 3  # network.AUTH_WPA2_PSK on the ESP32 port


class WifiLink:
    def __init__(self, cfg, network):
        self.cfg = cfg
        self.net = network
        self.state = OFF
        self.ap_active = False
        self.ip = ""
        self.attempts = 0  # connection attempts since the link was last up
        self.connects = 0  # times the link came up
        self.backoff_ms = cfg["backoff_min_ms"]
        self._sta = None
        self._due_ms = 0
        self._started = False

    def start(self, t_ms):
        """Bring up the interfaces the config asks for (once: an app restart keeps the link);
        returns event texts."""
        if self._started:
            return ()
        self._started = True
        out = []
        c = self.cfg
        try:
            ap = self.net.WLAN(self.net.AP_IF)
            if c["ap_enabled"] and 8 <= len(c["ap_password"]) <= 63 and c["ap_ssid"]:
                ap.active(True)
                ap.config(essid=c["ap_ssid"], password=c["ap_password"],
                          authmode=getattr(self.net, "AUTH_WPA2_PSK", _AUTH_WPA2_PSK))
                self.ap_active = True
                out.append("access point '%s' on (WPA2)" % c["ap_ssid"])
            else:
                ap.active(False)  # never an open access point
                if c["ap_enabled"]:
                    out.append("access point not started: wifi.ap_ssid must be set and "
                               "wifi.ap_password be 8 to 63 characters (no open access point)")
        except Exception as e:
            out.append("access point failed: %s" % _kind(e))
        if not c["enabled"]:
            return out
        if not c["ssid"]:
            out.append("station off: wifi.ssid is empty")
            return out
        try:
            self._sta = self.net.WLAN(self.net.STA_IF)
            self._sta.active(True)
        except Exception as e:
            self._sta = None
            out.append("station failed: %s" % _kind(e))
            return out
        out.append(self._connect(t_ms))
        return out

    def is_up(self):
        return self.state == UP

    def poll(self, t_ms):
        """Advance the state machine; returns event texts (usually none)."""
        sta = self._sta
        if sta is None:
            return ()
        try:
            connected = bool(sta.isconnected())
        except Exception:
            connected = False
        if self.state == CONNECTING:
            if connected:
                self.state = UP
                self.connects += 1
                self.attempts = 0
                self.backoff_ms = self.cfg["backoff_min_ms"]
                self.ip = _ip(sta)
                return ("up: '%s', address %s" % (self.cfg["ssid"], self.ip),)
            if ticks_diff(t_ms, self._due_ms) >= 0:
                return (self._give_up(t_ms, "no connection to '%s' within %d ms (status %s)" % (
                    self.cfg["ssid"], self.cfg["connect_timeout_ms"], _status(sta))),)
        elif self.state == UP:
            if not connected:
                self.ip = ""
                return ("lost '%s' (status %s)" % (self.cfg["ssid"], _status(sta)), self._connect(t_ms))
        elif self.state == RETRY and ticks_diff(t_ms, self._due_ms) >= 0:
            return (self._connect(t_ms),)
        return ()

    def _connect(self, t_ms):
        self.attempts += 1
        try:
            self._sta.connect(self.cfg["ssid"], self.cfg["password"])
        except Exception as e:
            return self._give_up(t_ms, "connect to '%s' failed: %s" % (self.cfg["ssid"], _kind(e)))
        self.state = CONNECTING
        self._due_ms = ticks_add(t_ms, self.cfg["connect_timeout_ms"])
        return "connecting to '%s' (attempt %d)" % (self.cfg["ssid"], self.attempts)

    def _give_up(self, t_ms, why):
        try:
            self._sta.disconnect()
        except Exception:
            pass
        self.state = RETRY
        wait = self.backoff_ms
        self._due_ms = ticks_add(t_ms, wait)
        self.backoff_ms = min(2 * wait, self.cfg["backoff_max_ms"])
        return "%s; retry in %d s" % (why, (wait + 500) // 1000)


def _ip(sta):
    try:
        return sta.ifconfig()[0]
    except Exception:
        return "?"


def _status(sta):
    try:
        return sta.status()
    except Exception:
        return "?"


def _kind(e):
    """An exception without its arguments (they could hold what was passed in)."""
    return type(e).__name__
