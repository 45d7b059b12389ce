# Pages and the SSD1306 driver under the unix port: pixels where they belong, text drawn, bar
# direction, overlays, and the main page against the reference images in tests/data/hmi/
# (regenerate with `trackpilot hmi refs` after an intended change, then look at the PNGs).
import tpassert as T

try:
    import framebuf
except ImportError:
    framebuf = None
    print("skipped: no framebuf")

W = 128
H = 64
REF_DIR = "tests/data/hmi/"
REF_SAMPLES = ("auto_right", "auto_left_far", "standby_refused", "estop")


def _setup():
    from tphmi.pages import Pages

    buf = bytearray(W * H // 8)
    fb = framebuf.FrameBuffer(buf, W, H, framebuf.MONO_VLSB)
    return buf, fb, Pages(fb)


def px(buf, x, y):
    return (buf[(y >> 3) * W + x] >> (y & 7)) & 1


def count(buf, x0, y0, x1, y1):
    n = 0
    for y in range(y0, y1):
        for x in range(x0, x1):
            n += px(buf, x, y)
    return n


def text_at(buf, s, x, y, inverted=False):
    """True when string s is drawn exactly at (x, y) with the 8x8 font."""
    ref = bytearray(len(s) * 8)
    rfb = framebuf.FrameBuffer(ref, len(s) * 8, 8, framebuf.MONO_VLSB)
    rfb.text(s, 0, 0, 1)
    for cx in range(len(s) * 8):
        for cy in range(8):
            want = (ref[cx] >> cy) & 1
            if inverted:
                want ^= 1
            if px(buf, x + cx, y + cy) != want:
                return False
    return True


def _st(name, **ch):
    from tphmi.preview.samples import sample

    st = sample(name)
    st.update(ch)
    return st


def test_main_page_text():
    if framebuf is None:
        return
    buf, fb, p = _setup()
    p.render(_st("auto_right"), 0, 0)
    T.true(text_at(buf, "AUTO", 1, 1, inverted=True), "mode label")
    T.true(text_at(buf, "FIX", W - 24, 1), "RTK state")
    T.true(text_at(buf, "HDG 123 CMD 126", 0, 38), "heading vs command")
    T.true(text_at(buf, " 4.5km/h 1185rpm", 0, 47), "speed and rpm")
    T.true(text_at(buf, "LEG 3/11", 0, 56), "leg i/N")
    T.true(text_at(buf, "187m", W - 32, 56), "distance to wp")
    T.true(count(buf, 0, 11, 80, 27) > 150, "2x xte digits drawn")


def test_xte_bar_follows_sign():
    if framebuf is None:
        return
    from tphmi.pages import BAR_Y

    buf, fb, p = _setup()
    inner = (BAR_Y + 2, BAR_Y + 5)
    for xte, right in ((2.5, True), (-2.5, False), (40.0, True), (-40.0, False)):
        p.render(_st("auto_right", xte_m=xte), 0, 0)
        r = count(buf, 66, inner[0], 126, inner[1])
        l = count(buf, 2, inner[0], 62, inner[1])
        if right:
            T.true(r > 0 and l == 0, "xte %r: right %d left %d" % (xte, r, l))
        else:
            T.true(l > 0 and r == 0, "xte %r: right %d left %d" % (xte, r, l))
    p.render(_st("auto_right", xte_m=2.5), 0, 0)
    small = count(buf, 66, inner[0], 126, inner[1])
    p.render(_st("auto_right", xte_m=5.0), 0, 0)
    T.true(count(buf, 66, inner[0], 126, inner[1]) > 1.8 * small, "bar length grows with xte")
    p.render(_st("auto_right", nav_valid=False), 0, 0)
    T.eq(count(buf, 66, inner[0], 126, inner[1]) + count(buf, 2, inner[0], 62, inner[1]), 0, "no bar without track")
    T.true(text_at(buf, "NO TRACK", 0, 56))


def test_refusal_overlay_every_page():
    if framebuf is None:
        return
    buf, fb, p = _setup()
    for page in range(4):
        p.render(_st("standby_refused"), page, 0)
        T.true(text_at(buf, "AUTO REFUSED:", 1, 64 - 27 - 1 + 1, inverted=True), "page %d" % page)
        T.true(text_at(buf, "no RTK fixed", 0, 64 - 27 - 1 + 10, inverted=True), "reason page %d" % page)


def test_other_pages():
    if framebuf is None:
        return
    buf, fb, p = _setup()
    p.render(_st("auto_right"), 1, 0)
    T.true(text_at(buf, "GNSS", 1, 1, inverted=True))
    T.true(text_at(buf, "RTK fixed", 0, 11))
    T.true(text_at(buf, "N 51.4987654", 0, 47))
    T.true(text_at(buf, "E 3.6123456", 0, 56))
    p.render(_st("auto_right", lat_e7=-338765432, lon_e7=-1512345), 1, 0)
    T.true(text_at(buf, "S 33.8765432", 0, 47))
    T.true(text_at(buf, "W 0.1512345", 0, 56))
    T.true(not text_at(buf, "CFG!", 128 - 4 * 8, 38))
    p.render(_st("auto_right", gnss_cfg_failed=True), 1, 0)  # issue 12: the VALSET session failed
    T.true(text_at(buf, "CFG!", 128 - 4 * 8, 38), "receiver configuration failure shown")
    p.render(_st("auto_right"), 2, 0)
    T.true(text_at(buf, "PILOT", 1, 1, inverted=True))
    T.true(text_at(buf, "ST  auto", 0, 20))
    T.true(text_at(buf, "compass   131.0", 0, 29))
    T.true(text_at(buf, "locked    133.0", 0, 38))
    T.true(text_at(buf, "keys        412", 0, 47))
    T.true(text_at(buf, "hang rec      1", 0, 56))
    p.render(_st("auto_right", pilot_hunts=True), 2, 0)  # issue 10: the pilot watch's advice
    T.true(text_at(buf, "HUNTS:lower gain", 0, 47), "pilot hunting shown")
    p.render(_st("alarm_gnss"), 3, 0)
    T.true(text_at(buf, "ALARMS 2", 1, 1, inverted=True))
    T.true(text_at(buf, " gnss", 0, 11), "acknowledged alarm without !")
    T.true(text_at(buf, "!gnss timeout", 0, 20), "sounding alarm with !")
    T.true(text_at(buf, "RTK lost for", 0, 29), "reason wrapped")
    T.true(text_at(buf, "E-stop off", 0, 56))
    p.render(_st("estop"), 0, 0)
    T.true(text_at(buf, "E-STOP INPUT ON", 4, 1, inverted=True), "E-stop input in the header")


def test_hold_progress_and_message():
    if framebuf is None:
        return
    buf, fb, p = _setup()
    p.render(_st("auto_right", mode=0), 0, 0, 0.5)
    T.true(text_at(buf, "HOLD AUTO", 0, 56))
    T.true(text_at(buf, " 4.5km/h 1185rpm", 0, 47), "the row above stays intact")
    T.eq(count(buf, 78, 58, 102, 62), 96, "left half of the progress bar filled")
    T.eq(count(buf, 103, 58, 126, 62), 0, "right half empty")
    p.message("hold longer", 1000, 1500)
    p.render(_st("auto_right"), 0, 2000)
    T.true(text_at(buf, "hold longer", 20, 56, inverted=True))
    T.true(text_at(buf, " 4.5km/h 1185rpm", 0, 47), "the row above stays intact")
    p.render(_st("auto_right"), 0, 2600)
    T.true(text_at(buf, "LEG 3/11", 0, 56), "message gone after its time")


def test_link_lost():
    if framebuf is None:
        return
    buf, fb, p = _setup()
    p.link_lost(12, _st("auto_right"))
    T.true(text_at(buf, "no status   12s", 0, 34))
    T.true(text_at(buf, "last: AUTO", 0, 44))
    T.true(text_at(buf, "state UNKNOWN", 0, 55))


def _read_pbm(path):
    with open(path, "rb") as f:
        data = f.read()
    # "P4\n128 64\n" + rows, MSB first
    parts = data.split(b"\n", 2)
    T.eq(parts[0], b"P4")
    w, h = [int(v) for v in parts[1].split()]
    return w, h, parts[2]


def test_main_page_matches_reference_images():
    if framebuf is None:
        return
    from tphmi.preview.samples import sample

    buf, fb, p = _setup()
    for name in REF_SAMPLES:
        w, h, rows = _read_pbm(REF_DIR + "main_%s.pbm" % name)
        T.eq((w, h), (W, H))
        p.render(sample(name), 0, 300)
        diff = 0
        for y in range(H):
            for x in range(W):
                ref = (rows[y * (W // 8) + (x >> 3)] >> (7 - (x & 7))) & 1
                if ref != px(buf, x, y):
                    diff += 1
        T.eq(diff, 0, "main page %s differs from the reference in %d pixels" % (name, diff))


class FakeI2C:
    def __init__(self):
        self.cmds = []
        self.data = []

    def writeto(self, addr, b):
        T.eq(addr, 0x3D)
        T.eq(b[0], 0x80, "command control byte")
        self.cmds.append(b[1])

    def writevto(self, addr, bufs):
        T.eq(addr, 0x3D)
        self.data.append(b"".join(bytes(x) for x in bufs))


def test_ssd1306_driver():
    if framebuf is None:
        return
    from tphmi.ssd1306 import SSD1306

    i2c = FakeI2C()
    d = SSD1306(i2c, addr=0x3D)
    T.eq(i2c.cmds[0], 0xAE, "display off first")
    T.true(0x8D in i2c.cmds and i2c.cmds[i2c.cmds.index(0x8D) + 1] == 0x14, "charge pump on")
    T.true(0xAF in i2c.cmds, "display on")
    T.eq(i2c.cmds[i2c.cmds.index(0xA8) + 1], 63, "multiplex 64 rows")
    i2c.cmds = []
    i2c.data = []
    d.fb.pixel(0, 0, 1)
    d.fb.pixel(127, 63, 1)
    d.show()
    T.eq(i2c.cmds, [0x21, 0, 127, 0x22, 0, 7], "column and page window")
    T.eq(len(i2c.data), 1)
    frame = i2c.data[0]
    T.eq(len(frame), 1 + 1024)
    T.eq(frame[0], 0x40, "data control byte")
    T.eq(frame[1], 0x01, "pixel (0,0): page 0 column 0 bit 0")
    T.eq(frame[1024], 0x80, "pixel (127,63): page 7 column 127 bit 7")
    T.eq(sum(frame[2:1024]), 0)
