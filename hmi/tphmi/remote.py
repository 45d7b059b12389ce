"""Remote HMI box (a second ESP32): the boat's pages from telemetry, authenticated commands back.

Pure part `RemoteHmi`: status datagrams and button events in (with t_ms), command packets and a
rendered framebuffer out. After `link_timeout_ms` without a valid status it draws the link-lost
page instead of stale data. PAGE is local; ENGAGE, STANDBY, NEXT_WP, PREV_WP, ACK and TRIAL (PAGE held 3 s) are signed
with the per-boat key (tphmi.auth) and sent; the boat's mode machine decides, the remote shows the
outcome from the next status (including an engage refusal and its reason).

Shell part (`run_remote`, asyncio, non-blocking UDP socket) and the ESP32 entry `main()` that reads
/hmi_remote.json (docs/HMI.md) and joins the boat's Wi-Fi as a station (never an access point).

Usage (pure, as in the tests):
    r = RemoteHmi(pages, signer, boat_id=7, link_timeout_ms=3000)
    r.on_datagram(data, t_ms)                  # True when it was a valid status for this boat
    for pkt in r.on_events(["STANDBY"], t_ms): sock.sendto(pkt, boat_addr)
    r.render(t_ms)                             # then oled.show()
"""
from trackpilot.compat import ticks_diff

from tphmi.pages import N_PAGES, PAGE_MAIN
from tphmi.status import HmiStatus, decode_status

_SIGNED = ("ENGAGE", "STANDBY", "NEXT_WP", "PREV_WP", "ACK", "TRIAL")


class RemoteHmi:
    def __init__(self, pages, signer, boat_id, link_timeout_ms=3000):
        self.pages = pages
        self.signer = signer
        self.boat_id = boat_id
        self.link_timeout_ms = link_timeout_ms
        self.status = HmiStatus()
        self._scratch = HmiStatus()
        self.have_status = False
        self.last_rx_ms = 0
        self.page = PAGE_MAIN
        self.bad_datagrams = 0
        self.last_error = ""

    def on_datagram(self, data, t_ms):
        """Feed one received datagram. Garbage and other boats' status are counted and ignored."""
        try:
            decode_status(data, self._scratch)
        except (ValueError, IndexError) as e:
            self.bad_datagrams += 1
            self.last_error = str(e)
            return False
        boat_id = self._scratch.boat_id  # pyright: ignore[reportAttributeAccessIssue] (set from FIELDS)
        if boat_id != self.boat_id:
            self.bad_datagrams += 1
            self.last_error = "status from boat %d" % boat_id
            return False
        self.status, self._scratch = self._scratch, self.status
        self.have_status = True
        self.last_rx_ms = t_ms
        return True

    def link_ok(self, t_ms):
        return self.have_status and ticks_diff(t_ms, self.last_rx_ms) < self.link_timeout_ms

    def on_events(self, events, t_ms):
        """Button events -> list of command packets to send (PAGE and hints act locally)."""
        out = []
        for ev in events:
            if ev == "PAGE":
                self.page = (self.page + 1) % N_PAGES
            elif ev == "HOLD_LONGER":
                self.pages.message("hold longer", t_ms, 1500)
            elif ev in _SIGNED:
                try:
                    out.append(self.signer.sign(ev))
                    self.pages.message("sent " + ev, t_ms, 1500)
                except Exception as e:  # cannot persist the counter: send nothing, say so
                    self.last_error = str(e)
                    self.pages.message("SEND FAILED", t_ms, 3000)
        return out

    def render(self, t_ms, engage_progress=0.0):
        if self.link_ok(t_ms):
            self.pages.render(self.status, self.page, t_ms, engage_progress)
        elif self.have_status:
            self.pages.link_lost(ticks_diff(t_ms, self.last_rx_ms) // 1000, self.status)
        else:
            self.pages.link_lost(-1, None)


# ---------------------------------------------------------------------- asyncio shell
async def run_remote(remote, sock, boat_addr, buttons, button_pins, show, indicators=None,
                     indicator_pins=None, ticks_ms=None, poll_ms=20, render_ms=200, wifi=None):
    """Main loop of the remote box. `sock` is a non-blocking UDP socket bound to the status port;
    `show()` pushes the framebuffer to the display; `wifi`: a trackpilot.board.wifi.WifiLink to keep
    connected (reconnect with back-off; its events go to the console and last_error)."""
    import asyncio

    if ticks_ms is None:
        from time import ticks_ms
    last_render = ticks_ms()
    while True:
        t = ticks_ms()
        if wifi is not None:
            for text in wifi.poll(t):
                print("wifi:", text)
                remote.last_error = "wifi: " + text
        while True:  # drain the socket without blocking
            try:
                data, _ = sock.recvfrom(512)
            except OSError:
                break
            remote.on_datagram(data, t)
        events = buttons.update(button_pins.read(), t)
        for pkt in remote.on_events(events, t):
            try:
                sock.sendto(pkt, boat_addr)
            except OSError as e:
                remote.last_error = "send: %r" % e
        if indicators is not None and indicator_pins is not None:
            if remote.link_ok(t):
                indicators.update(remote.status, t)
            indicator_pins.apply(indicators)
        if events or ticks_diff(t, last_render) >= render_ms:
            remote.render(t, buttons.engage_progress(t))
            show()
            last_render = t
        await asyncio.sleep_ms(poll_ms)


async def command_listener(sock, verifier, on_command, on_refusal, poll_ms=20):
    """Boat side: receive command packets on a non-blocking UDP socket and verify them.
    on_command(name, addr) for accepted commands; on_refusal(reason, addr) for every refusal."""
    import asyncio

    while True:
        while True:
            try:
                data, addr = sock.recvfrom(64)
            except OSError:
                break
            name, why = verifier.verify(data)
            if name is None:
                on_refusal(why, addr)
            else:
                on_command(name, addr)
        await asyncio.sleep_ms(poll_ms)


def udp_socket(port):
    """A non-blocking UDP socket bound to `port` on all interfaces."""
    import socket

    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    s.bind(socket.getaddrinfo("0.0.0.0", port)[0][-1])
    s.setblocking(False)
    return s


def main(config_path="/hmi_remote.json"):  # pragma: no cover - ESP32 only
    """ESP32 entry point of the remote box (see docs/HMI.md for the config file)."""
    import asyncio
    import json
    import time

    import network
    from machine import I2C, Pin

    from tphmi.auth import CommandSigner, FileStore
    from tphmi.buttons import ButtonPins, Buttons
    from tphmi.pages import Pages
    from tphmi.ssd1306 import SSD1306

    with open(config_path) as f:
        cfg = json.load(f)
    from trackpilot.board.wifi import WifiLink

    # station with reconnect and back-off; the access point is switched off (never an open one)
    link = WifiLink({"enabled": True, "ssid": cfg["wifi_ssid"], "password": cfg["wifi_password"],
                     "ap_enabled": False, "ap_ssid": "", "ap_password": "", "connect_timeout_ms": 15000,
                     "backoff_min_ms": 2000, "backoff_max_ms": 30000}, network)
    for text in link.start(time.ticks_ms()):
        print("wifi:", text)
    with open(cfg.get("key_file", "/hmi.key"), "rb") as f:
        key = f.read()
    signer = CommandSigner(key, cfg["boat_id"], FileStore(cfg.get("counter_file", "/auth_tx.bin")))
    w = cfg["wiring"]
    oled = SSD1306(I2C(0, scl=Pin(w["scl"]), sda=Pin(w["sda"]), freq=400000), addr=w.get("oled_addr", 0x3C))
    pages = Pages(oled.fb)
    remote = RemoteHmi(pages, signer, cfg["boat_id"], int(cfg.get("link_timeout_s", 3) * 1000))
    pins = [Pin(p, Pin.IN, Pin.PULL_UP) if p is not None else None for p in w["buttons"]]
    sock = udp_socket(cfg.get("status_port", 10111))
    boat = socket_addr(cfg["boat_host"], cfg.get("command_port", 10112))
    asyncio.run(run_remote(remote, sock, boat, Buttons(), ButtonPins(pins), oled.show, ticks_ms=time.ticks_ms,
                           wifi=link))


def socket_addr(host, port):
    import socket

    return socket.getaddrinfo(host, port)[0][-1]
