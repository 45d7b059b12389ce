"""The HMI on the boat's own ESP32: display, buttons, LEDs, buzzer, status telemetry, remote commands.

Built by the wiring (`wiring_esp32.Wiring._build_hmi`); the application calls, from its inputs and
telemetry tasks:
    poll_commands(t_ms) -> list of (name, source): ("ENGAGE"|"STANDBY"|"NEXT_WP"|"PREV_WP"|"ACK"|"TRIAL",
                           "HMI" or "remote"); PAGE is handled here
    show(app, t_ms)      fills the HmiStatus from the app, drives LEDs/buzzer, redraws (<= 5 Hz)
    send_status(app, t_ms)  one status datagram (docs/TELEMETRY.md) to telemetry.udp_host:status_port
    next_page()
    drain_events() -> [(kind, text)]: refused remote commands (AUTH_REFUSED) and HMI faults, for the log
Remote commands are accepted only when hmi.remote_enabled is true (default false), with the per-boat
key (hmi.key_file) and a valid counter state (hmi.counter_file); otherwise not one is taken and the
key file is not even read (docs/HMI.md).

Configuration (section "hmi", all optional): boat_id (0), key_file ("/hmi.key"),
counter_file ("/auth_rx.bin"), command_port (10112), render_ms (200), remote_enabled (false).

Usage (tests build it with fakes):
    hmi = BoardHmi(wiring, cfg)           # wiring.i2c, wiring.buttons, wiring.leds, wiring.estop_active()
    for name, source in hmi.poll_commands(t_ms): app.command(name, source)
"""
from trackpilot.compat import ticks_diff

from tphmi.buttons import ButtonPins, Buttons
from tphmi.indicators import IndicatorPins, Indicators
from tphmi.status import HmiStatus, encode_status, status_from_app

# wiring.buttons names -> order of tphmi.buttons.BUTTONS
_BUTTON_NAMES = ("ENGAGE", "STANDBY", "NEXT_WP", "PREV_WP", "PAGE", "ACK")
_COMMANDS = ("ENGAGE", "STANDBY", "NEXT_WP", "PREV_WP", "ACK", "TRIAL")


class BoardHmi:
    def __init__(self, wiring, cfg, sock=None, status_addr=None):
        hc = cfg.get("hmi", {}) if hasattr(cfg, "get") else {}
        tc = cfg.get("telemetry", {}) if hasattr(cfg, "get") else {}
        self.w = wiring
        self.boat_id = hc.get("boat_id", 0)
        self.render_ms = hc.get("render_ms", 200)
        self._events = []
        self.status = HmiStatus()
        self.status.boat_id = self.boat_id
        self.page = 0
        self._last_render = None
        self._dirty = True
        # display (optional: the boat still runs without one)
        self.oled = None
        self.pages = None
        i2c = getattr(wiring, "i2c", None)
        if i2c is not None:
            try:
                from tphmi.pages import Pages
                from tphmi.ssd1306 import SSD1306

                self.oled = SSD1306(i2c, addr=wiring.cfg.get("display_addr", 0x3C))
                self.pages = Pages(self.oled.fb)
            except (OSError, ImportError) as e:
                self.oled = None
                self._event("HMI", "display not available: %r" % e)
        bmap = getattr(wiring, "buttons", {}) or {}
        self.buttons = Buttons()
        self.button_pins = ButtonPins([bmap.get(n) for n in _BUTTON_NAMES])
        leds = getattr(wiring, "leds", {}) or {}
        self.indicators = Indicators()
        self.indicator_pins = IndicatorPins(leds.get("led_gps"), leds.get("led_auto"), leds.get("led_alarm"),
                                            leds.get("buzzer"))
        # network: status out, authenticated commands in
        self.sock = sock
        self.status_addr = status_addr
        self.verifier = None
        self._net_cfg = (tc.get("enabled", False), tc.get("udp_host", "255.255.255.255"),
                         tc.get("status_port", 10111), hc.get("command_port", 10112))
        self._setup_auth(hc)

    def _event(self, kind, text):
        if len(self._events) < 32:
            self._events.append((kind, text))

    def drain_events(self):
        ev = self._events
        self._events = []
        if self.verifier is not None:
            ev.extend(self.verifier.drain_events())
        return ev

    def _setup_auth(self, hc):
        if hc.get("remote_enabled", False) is not True:
            self._event("HMI", "remote commands disabled (hmi.remote_enabled is false)")
            return
        try:
            from tphmi.auth import AuthError, CommandVerifier, FileStore
        except ImportError:
            return
        key_file = hc.get("key_file", "/hmi.key")
        try:
            with open(key_file, "rb") as f:
                key = f.read()
        except OSError:
            self._event("HMI", "no key file %s: remote commands disabled" % key_file)
            return
        try:
            self.verifier = CommandVerifier(key, self.boat_id, FileStore(hc.get("counter_file", "/auth_rx.bin")))
        except AuthError as e:
            self._event("HMI", "remote commands disabled: %s" % e)
            return
        if self.verifier.state_error:
            self._event("HMI", "remote commands refused: %s" % self.verifier.state_error)

    def _open_socket(self):
        """Shell: one non-blocking UDP socket on the command port, also used to send status."""
        if self.sock is not None:
            return self.sock
        enabled, host, status_port, command_port = self._net_cfg
        if not enabled:
            return None
        try:
            import socket

            from tphmi.remote import udp_socket

            self.sock = udp_socket(command_port)
            try:
                self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
            except (OSError, AttributeError):
                pass
            self.status_addr = socket.getaddrinfo(host, status_port)[0][-1]
        except (OSError, ImportError) as e:
            self._net_cfg = (False,) + self._net_cfg[1:]  # do not retry every 50 ms
            self._event("HMI", "telemetry socket not available: %r" % e)
            return None
        return self.sock

    # ------------------------------------------------------------------ app interface
    def poll_commands(self, t_ms):
        out = []
        for ev in self.buttons.update(self.button_pins.read(), t_ms):
            self._dirty = True
            if ev == "PAGE":
                self.next_page()
            elif ev == "HOLD_LONGER":
                if self.pages is not None:
                    self.pages.message("hold longer", t_ms, 1500)
            elif ev in _COMMANDS:
                out.append((ev, "HMI"))
        if self.buttons.pressed(0):
            self._dirty = True  # AUTO being held: redraw the progress bar
        sock = self._open_socket() if self.verifier is not None else None
        if sock is not None:
            for _ in range(4):  # bounded per call: a flood cannot starve the app
                try:
                    data, addr = sock.recvfrom(64)
                except OSError:
                    break
                name, why = self.verifier.verify(data)
                if name is not None:
                    out.append((name, "remote"))
        return out

    def next_page(self):
        self.page = (self.page + 1) % 4
        self._dirty = True

    def show(self, app, t_ms):
        st = status_from_app(app, t_ms, self.status)
        if self.verifier is not None:
            st.cmd_counter = self.verifier.last if not self.verifier.state_error else 0
        self.indicators.update(st, t_ms)
        self.indicator_pins.apply(self.indicators)
        if self.oled is None:
            return
        if self._dirty or self._last_render is None or ticks_diff(t_ms, self._last_render) >= self.render_ms:
            self.pages.render(st, self.page, t_ms, self.buttons.engage_progress(t_ms))
            try:
                self.oled.show()  # about 25 ms on a 400 kHz bus
            except OSError as e:
                self._event("HMI", "display write failed: %r" % e)
            self._last_render = t_ms
            self._dirty = False

    def send_status(self, app, t_ms):
        sock = self._open_socket()
        if sock is None or self.status_addr is None:
            return
        st = status_from_app(app, t_ms, self.status)
        st.seq = (st.seq + 1) & 0xFFFF
        try:
            sock.sendto(encode_status(st), self.status_addr)
        except OSError:
            pass  # no network right now: telemetry is best effort

