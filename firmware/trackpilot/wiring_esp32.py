"""Wiring for the ESP32 (reference hardware: ESP32-S3 N16R8, docs/WIRING.md).

Builds the UARTs, the I2C bus, the pins and the watchdog from the `wiring` section of the
configuration. The simulator's twin is `wiring_sim.py`; the application cannot tell them apart.
Only this module and boot/main touch `machine`; Wi-Fi's logic is in wifi.py (WifiLink), fed\nthe real `network` module here.

Usage (main.py):
    w = Wiring(cfg)
    app = App(w, cfg, problems, reset_cause=w.reset_cause())
"""
import machine
import os
import time

# machine.reset_cause() codes (ESP32 port)
_CAUSES = {
    getattr(machine, "PWRON_RESET", 1): "power-on",
    getattr(machine, "HARD_RESET", 2): "hard reset",
    getattr(machine, "WDT_RESET", 3): "watchdog",
    getattr(machine, "DEEPSLEEP_RESET", 4): "deep sleep",
    getattr(machine, "SOFT_RESET", 5): "soft reset",
}


class Wiring:
    def __init__(self, cfg, data_dir=""):
        w = cfg["wiring"]
        self.cfg = w
        self.cfg_all = cfg
        self._nmea_sock = None
        self.ticks_ms = time.ticks_ms  # wraps at 2**30 on the ESP32, like trackpilot.compat
        self.gnss_uart = machine.UART(w["gnss_uart"], baudrate=w["gnss_baud"], tx=w["gnss_tx"],
                                      rx=w["gnss_rx"], rxbuf=2048, timeout=0)
        inv = 0
        if w["seatalk_invert"]:
            inv = machine.UART.INV_TX | machine.UART.INV_RX
        # timeout_char below one character time (3 ms at 4800 Bd) makes MicroPython set the
        # IDF RX timeout to 1 character and the RX FIFO threshold to 1 byte: the echo of each
        # byte is readable ~2.5 ms after the write, not after the IDF default of 10 idle
        # characters (~23 ms). Older ports ignore it; pilot.echo_timeout_ms (40) covers both.
        self.seatalk_uart = machine.UART(w["seatalk_uart"], baudrate=4800, bits=8, parity=0,
                                         tx=w["seatalk_tx"], rx=w["seatalk_rx"], invert=inv,
                                         rxbuf=512, timeout=0, timeout_char=1)
        self.motor_uart = None
        if cfg["motor"]["link"] == "rs232":
            self.motor_uart = machine.UART(w["motor_uart"], baudrate=w["motor_baud"], tx=w["motor_tx"],
                                           rx=w["motor_rx"], rxbuf=256, timeout=0)
        self.throttle = None
        if cfg["motor"]["link"] == "pwm" and w["throttle_pwm"] >= 0:
            self.throttle = machine.PWM(machine.Pin(w["throttle_pwm"]), freq=1000, duty_u16=0)
        self.wind_uart = None  # wind via SeaTalk 0x10/0x11 or an SC16IS75x expander (docs/WIRING.md)
        self.i2c = None
        if w["i2c_sda"] >= 0 and w["i2c_scl"] >= 0:
            self.i2c = machine.I2C(0, sda=machine.Pin(w["i2c_sda"]), scl=machine.Pin(w["i2c_scl"]), freq=400000)
        self.buttons = {}
        for name, key in (("ENGAGE", "btn_engage"), ("STANDBY", "btn_standby"), ("NEXT_WP", "btn_next"),
                          ("PREV_WP", "btn_prev"), ("PAGE", "btn_page"), ("ACK", "btn_ack")):
            if w[key] >= 0:
                self.buttons[name] = machine.Pin(w[key], machine.Pin.IN, machine.Pin.PULL_UP)
        self.estop_pin = machine.Pin(w["estop_in"], machine.Pin.IN, machine.Pin.PULL_UP) if w["estop_in"] >= 0 else None
        self.leds = {}
        for key in ("led_gps", "led_auto", "led_alarm", "buzzer"):
            if w[key] >= 0:
                self.leds[key] = machine.Pin(w[key], machine.Pin.OUT, value=0)
        self.wdt = machine.WDT(timeout=w["watchdog_ms"])
        self.log_dir = data_dir + "/log"
        self.state_path = data_dir + "/state.json"
        self.rand = _seeded_prng()  # StLink's random back-off (needs .randint)
        self.wifi = None
        if cfg["wifi"]["enabled"] or cfg["wifi"]["ap_enabled"]:
            import network

            from trackpilot.wifi import WifiLink

            self.wifi = WifiLink(cfg["wifi"], network)  # started and polled by the app (task_wifi)
        self.hmi = None
        self._build_hmi(cfg)

    def _build_hmi(self, cfg):
        try:
            from tphmi.board import BoardHmi
        except ImportError:
            return
        self.hmi = BoardHmi(self, cfg)

    def link_up(self):
        """The Wi-Fi station is connected (UDP and TCP can go out)."""
        return self.wifi is not None and self.wifi.is_up()

    def reset_cause(self):
        return _CAUSES.get(machine.reset_cause(), "unknown")

    def statvfs(self, path):
        return os.statvfs(path)

    def debug(self, msg):
        pass  # the log holds everything; the USB console stays quiet for mpremote

    def estop_active(self):
        if self.estop_pin is None:
            return False
        v = self.estop_pin.value()
        return v == 0 if self.cfg["estop_active_low"] else v == 1

    def poll_commands(self, t_ms):
        if self.hmi is not None:
            return self.hmi.poll_commands(t_ms)
        return ()

    def next_page(self):
        if self.hmi is not None:
            self.hmi.next_page()

    def show(self, app, t_ms):
        if self.hmi is not None:
            self.hmi.show(app, t_ms)

    def send_status(self, app, t_ms):
        if self.hmi is not None and self.link_up():
            self.hmi.send_status(app, t_ms)
        if self.cfg_all["telemetry"]["console"]:
            # for `trackpilot monitor --serial PORT` over the USB console
            import binascii

            from tphmi.status import encode_status, status_from_app

            print("TPS", binascii.hexlify(encode_status(status_from_app(app, t_ms))).decode())

    def send_nmea(self, data):
        """NMEA 0183 for chart plotters (OpenCPN listens on UDP 10110); best effort."""
        w = self.cfg_all["telemetry"]
        if not w["enabled"] or not self.link_up():
            return
        try:
            if self._nmea_sock is None:
                import socket

                self._nmea_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                self._nmea_sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
                self._nmea_addr = socket.getaddrinfo(w["udp_host"], w["udp_port"])[0][-1]
            self._nmea_sock.sendto(data, self._nmea_addr)
        except OSError:
            pass  # no network right now

    def set_throttle(self, duty):
        if self.throttle is not None:
            self.throttle.duty_u16(int(max(0.0, min(1.0, duty)) * 65535))

    def feed_watchdog(self):
        self.wdt.feed()

    def correction_age_s(self, t_ms):
        return None


def _seeded_prng():
    from trackpilot.stlink import Prng

    b = os.urandom(4)  # two boxes on one bus must not back off in step
    return Prng(b[0] | (b[1] << 8) | (b[2] << 16) | (b[3] << 24))
