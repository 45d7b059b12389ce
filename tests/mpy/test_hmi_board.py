# BoardHmi as the wiring builds it, with fake pins, I2C and socket, and a fake app around the real
# mode machine and Fix: buttons become commands, the page shows the app's state, LEDs follow,
# remote packets are verified, the status datagram goes out.
import tpassert as T
from trackpilot.core import modes
from trackpilot.nav.fix import Fix

try:
    import framebuf
except ImportError:
    framebuf = None
    print("skipped: no framebuf (display part)")
try:
    import hashlib
except ImportError:
    hashlib = None
    print("skipped: no hashlib (remote command part)")


class Pin:
    def __init__(self, v=1):
        self.v = v

    def value(self, v=None):
        if v is None:
            return self.v
        self.v = v


class I2C:
    def __init__(self):
        self.frames = 0

    def writeto(self, addr, b):
        pass

    def writevto(self, addr, bufs):
        self.frames += 1


class Wiring:
    def __init__(self, with_display):
        self.cfg = {"display_addr": 0x3C}
        self.i2c = I2C() if with_display else None
        self.buttons = {n: Pin(1) for n in ("ENGAGE", "STANDBY", "NEXT_WP", "PREV_WP", "PAGE", "ACK")}
        self.leds = {n: Pin(0) for n in ("led_gps", "led_auto", "led_alarm", "buzzer")}
        self.estop = False

    def estop_active(self):
        return self.estop

    def correction_age_s(self, t_ms):
        return 2.5


class Sock:
    def __init__(self):
        self.rx = []
        self.tx = []

    def recvfrom(self, n):
        if not self.rx:
            raise OSError(11)
        return self.rx.pop(0), ("1.2.3.4", 5)

    def sendto(self, data, addr):
        self.tx.append((data, addr))


class App:
    def __init__(self, w):
        self.w = w
        self.mm = modes.ModeMachine()
        self.fix = Fix()
        self.fix.pos_valid = True
        self.fix.rtk = 3
        self.fix.heading_valid = True
        self.fix.heading_deg = 90.0
        self.progress = None
        self.track = None
        self.heading_cmd_deg = None
        self.rpm_cmd = 0
        self.refusal = ""


def _press(hmi, w, name, ms, t):
    out = []
    w.buttons[name].v = 0
    for _ in range(ms // 10):
        out += hmi.poll_commands(t)
        t += 10
    w.buttons[name].v = 1
    for _ in range(10):
        out += hmi.poll_commands(t)
        t += 10
    return out, t


def test_buttons_to_commands_and_leds():
    from tphmi.board import BoardHmi

    w = Wiring(framebuf is not None)
    hmi = BoardHmi(w, {"hmi": {"boat_id": 7, "key_file": "/nonexistent/hmi.key"}})
    T.true(any("remote commands disabled" in t for _, t in hmi.drain_events()), "no key: said so")
    app = App(w)
    out, t = _press(hmi, w, "ENGAGE", 300, 0)
    T.eq(out, [], "short AUTO press: nothing")
    out, t = _press(hmi, w, "ENGAGE", 1200, t)
    T.eq(out, [("ENGAGE", "HMI")])
    out, t = _press(hmi, w, "STANDBY", 20, t)
    T.eq(out, [("STANDBY", "HMI")])
    out, t = _press(hmi, w, "PAGE", 100, t)
    T.eq(out, [], "PAGE handled by the HMI")
    T.eq(hmi.page, 1)
    out, t = _press(hmi, w, "PAGE", 3100, t)  # issue 11: PAGE held 3 s starts a trial (from STANDBY)
    T.eq(out, [("TRIAL", "HMI")])
    T.eq(hmi.page, 2)
    app.mm.engage(t, None)
    hmi.show(app, t)
    T.eq(w.leds["led_auto"].v, 1)
    T.eq(w.leds["led_gps"].v, 1, "RTK fixed: steady")
    T.eq(hmi.status.corr_age_s, 2.5)
    if framebuf is not None:
        T.true(w.i2c.frames >= 2, "display initialised and drawn")
    w.estop = True
    app.mm.estop(t, True)
    hmi.show(app, t + 1000)
    T.eq(hmi.status.estop_input, True)
    T.eq(hmi.status.mode, modes.ESTOP)


def test_remote_commands_and_status_out():
    if hashlib is None:
        return
    import time
    from tphmi.auth import CommandSigner, MemStore, init_state
    from tphmi.board import BoardHmi
    from tphmi.status import decode_status

    key = b"s" * 32
    base = "/tmp/tphmi_board_%d" % time.ticks_us()
    with open(base + ".key", "wb") as f:
        f.write(key)
    from tphmi.auth import FileStore

    init_state(FileStore(base + ".ctr"), key, 0)
    w = Wiring(False)
    sock = Sock()
    hmi = BoardHmi(w, {"hmi": {"boat_id": 7, "key_file": base + ".key", "counter_file": base + ".ctr",
                               "remote_enabled": True}},
                   sock=sock, status_addr=("9.9.9.9", 10111))
    tx = MemStore()
    init_state(tx, key)
    signer = CommandSigner(key, 7, tx)
    p1 = signer.sign("STANDBY")
    sock.rx = [p1, p1, b"junk", signer.sign("NEXT_WP")]
    T.eq(hmi.poll_commands(0), [("STANDBY", "remote"), ("NEXT_WP", "remote")])
    # issue 14.10: the same key and a valid packet, but remote_enabled false (the default)
    for enabled in ({}, {"remote_enabled": False}):
        cfg = {"boat_id": 7, "key_file": base + ".key", "counter_file": base + ".ctr"}
        cfg.update(enabled)
        sock_off = Sock()
        off = BoardHmi(w, {"hmi": cfg}, sock=sock_off, status_addr=("9.9.9.9", 10111))
        sock_off.rx = [signer.sign("ENGAGE")]
        T.eq(off.poll_commands(0), [])
        T.true(any("remote_enabled" in t for _, t in off.drain_events()), "disabled: said so")
    ev = hmi.drain_events()
    T.eq(len(ev), 2)
    T.true("replay" in ev[0][1] and "truncated" in ev[1][1], repr(ev))
    app = App(w)
    app.refusal = "no valid track loaded"
    hmi.show(app, 0)
    hmi.send_status(app, 0)
    hmi.send_status(app, 1000)
    T.eq(len(sock.tx), 2)
    st = decode_status(sock.tx[1][0])
    T.eq((st.boat_id, st.seq, st.refusal, st.cmd_counter), (7, 2, "no valid track loaded", 2))
    T.eq(sock.tx[1][1], ("9.9.9.9", 10111))
    import os

    for p in (base + ".key", base + ".ctr"):
        os.remove(p)
