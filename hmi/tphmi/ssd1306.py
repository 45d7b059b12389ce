"""A small SSD1306 OLED driver (128x64 or 128x32, I2C), framebuf-based. Written for trackpilot.

The display RAM is 8 pages of 8 rows, one byte per column per page, LSB on top: exactly
framebuf.MONO_VLSB, so `show()` sends the buffer as it is.

Usage (the wiring builds the bus):
    from machine import I2C, Pin
    from tphmi.ssd1306 import SSD1306
    oled = SSD1306(I2C(0, scl=Pin(9), sda=Pin(8), freq=400000), addr=0x3C)
    oled.fb.text("hello", 0, 0, 1)
    oled.show()                        # about 25 ms at 400 kHz for 1 KB
"""
import framebuf

from trackpilot.compat import const

_SET_CONTRAST = const(0x81)
_ENTIRE_ON_RESUME = const(0xA4)  # show RAM (0xA5 would light every pixel)
_NORM = const(0xA6)  # 0xA7 inverts
_DISP_OFF = const(0xAE)
_DISP_ON = const(0xAF)
_MEM_MODE = const(0x20)  # 0x00 = horizontal addressing
_COL_ADDR = const(0x21)
_PAGE_ADDR = const(0x22)
_START_LINE = const(0x40)
_SEG_REMAP = const(0xA1)  # column 127 is SEG0: normal orientation on most modules
_MUX_RATIO = const(0xA8)
_COM_SCAN_DEC = const(0xC8)
_DISP_OFFSET = const(0xD3)
_COM_PINS = const(0xDA)
_CLK_DIV = const(0xD5)
_PRECHARGE = const(0xD9)
_VCOM_DESEL = const(0xDB)
_CHARGE_PUMP = const(0x8D)
_CTRL_CMD = const(0x80)  # control byte: one command follows
_CTRL_DATA = const(0x40)  # control byte: display data follows


class SSD1306:
    """SSD1306 on an I2C bus. `fb` is the framebuf.FrameBuffer to draw on; `show()` sends it."""

    def __init__(self, i2c, addr=0x3C, width=128, height=64, external_vcc=False, init=True):
        self.i2c = i2c
        self.addr = addr
        self.width = width
        self.height = height
        self.pages = height // 8
        self.external_vcc = external_vcc
        self.buf = bytearray(width * self.pages)
        self.fb = framebuf.FrameBuffer(self.buf, width, height, framebuf.MONO_VLSB)
        self._cmd_buf = bytearray(2)
        self._data_prefix = bytes((_CTRL_DATA,))
        if init:
            self.init_display()

    def cmd(self, c):
        self._cmd_buf[0] = _CTRL_CMD
        self._cmd_buf[1] = c
        self.i2c.writeto(self.addr, self._cmd_buf)

    def init_display(self):
        for c in (
            _DISP_OFF,
            _MEM_MODE, 0x00,
            _START_LINE | 0,
            _SEG_REMAP,
            _MUX_RATIO, self.height - 1,
            _COM_SCAN_DEC,
            _DISP_OFFSET, 0x00,
            _COM_PINS, 0x12 if self.height == 64 else 0x02,
            _CLK_DIV, 0x80,
            _PRECHARGE, 0x22 if self.external_vcc else 0xF1,
            _VCOM_DESEL, 0x30,
            _SET_CONTRAST, 0xFF,
            _ENTIRE_ON_RESUME,
            _NORM,
            _CHARGE_PUMP, 0x10 if self.external_vcc else 0x14,
            _DISP_ON,
        ):
            self.cmd(c)
        self.fb.fill(0)
        self.show()

    def power(self, on):
        self.cmd(_DISP_ON if on else _DISP_OFF)

    def contrast(self, level):
        self.cmd(_SET_CONTRAST)
        self.cmd(level & 0xFF)

    def invert(self, on):
        self.cmd(0xA7 if on else _NORM)

    def show(self):
        for c in (_COL_ADDR, 0, self.width - 1, _PAGE_ADDR, 0, self.pages - 1):
            self.cmd(c)
        # One transaction, no copy: control byte then the whole buffer.
        self.i2c.writevto(self.addr, (self._data_prefix, self.buf))
