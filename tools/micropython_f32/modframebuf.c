// trackpilot f32 port: `framebuf` module, our own, with the API of MicroPython's:
// FrameBuffer(buffer, width, height, format[, stride]) with fill, fill_rect, pixel, hline,
// vline, rect, line, text, scroll and blit, and the formats MONO_VLSB (MVLSB), MONO_HLSB,
// MONO_HMSB, RGB565, GS2_HMSB, GS4_HMSB and GS8.  Not implemented: ellipse, poly.
// text() uses the unix port's 8x8 font, rendered at build time by gen_font8x8.py into
// trackpilot_font8x8.h; without that header (no unix port with framebuf) there is no module.
#include <string.h>

#include "py/runtime.h"
#include "py/binary.h"

#if defined(__has_include)
#if __has_include("trackpilot_font8x8.h")
#include "trackpilot_font8x8.h"
#define TP_HAVE_FONT (1)
#endif
#endif

#if MICROPY_PY_FRAMEBUF && defined(TP_HAVE_FONT)

enum { FMT_MONO_VLSB = 0, FMT_RGB565 = 1, FMT_GS4_HMSB = 2, FMT_MONO_HLSB = 3, FMT_MONO_HMSB = 4,
       FMT_GS2_HMSB = 5, FMT_GS8 = 6 };

typedef struct _mp_obj_framebuf_t {
    mp_obj_base_t base;
    mp_obj_t buf_obj; // keeps the buffer alive
    uint8_t *buf;
    mp_int_t width, height, stride;
    uint8_t format;
} mp_obj_framebuf_t;

static const mp_obj_type_t mp_type_framebuf;

static void fb_set(const mp_obj_framebuf_t *fb, mp_int_t x, mp_int_t y, uint32_t c) {
    size_t i;
    switch (fb->format) {
        case FMT_MONO_VLSB:
            i = (y >> 3) * fb->stride + x;
            fb->buf[i] = (fb->buf[i] & ~(1 << (y & 7))) | ((c & 1) << (y & 7));
            break;
        case FMT_MONO_HLSB:
        case FMT_MONO_HMSB: {
            i = (x + y * fb->stride) >> 3;
            int bit = fb->format == FMT_MONO_HLSB ? 7 - (x & 7) : (x & 7);
            fb->buf[i] = (fb->buf[i] & ~(1 << bit)) | ((c & 1) << bit);
            break;
        }
        case FMT_RGB565:
            ((uint16_t *)fb->buf)[x + y * fb->stride] = (uint16_t)c;
            break;
        case FMT_GS2_HMSB: {
            i = (x + y * fb->stride) >> 2;
            int shift = (x & 3) << 1;
            fb->buf[i] = (fb->buf[i] & ~(3 << shift)) | ((c & 3) << shift);
            break;
        }
        case FMT_GS4_HMSB: {
            i = (x + y * fb->stride) >> 1;
            int shift = (x & 1) ? 0 : 4;
            fb->buf[i] = (fb->buf[i] & ~(0x0f << shift)) | ((c & 0x0f) << shift);
            break;
        }
        default: // GS8
            fb->buf[x + y * fb->stride] = (uint8_t)c;
            break;
    }
}

static uint32_t fb_get(const mp_obj_framebuf_t *fb, mp_int_t x, mp_int_t y) {
    switch (fb->format) {
        case FMT_MONO_VLSB:
            return (fb->buf[(y >> 3) * fb->stride + x] >> (y & 7)) & 1;
        case FMT_MONO_HLSB:
            return (fb->buf[(x + y * fb->stride) >> 3] >> (7 - (x & 7))) & 1;
        case FMT_MONO_HMSB:
            return (fb->buf[(x + y * fb->stride) >> 3] >> (x & 7)) & 1;
        case FMT_RGB565:
            return ((uint16_t *)fb->buf)[x + y * fb->stride];
        case FMT_GS2_HMSB:
            return (fb->buf[(x + y * fb->stride) >> 2] >> ((x & 3) << 1)) & 3;
        case FMT_GS4_HMSB:
            return (fb->buf[(x + y * fb->stride) >> 1] >> ((x & 1) ? 0 : 4)) & 0x0f;
        default:
            return fb->buf[x + y * fb->stride];
    }
}

static inline bool fb_inside(const mp_obj_framebuf_t *fb, mp_int_t x, mp_int_t y) {
    return x >= 0 && y >= 0 && x < fb->width && y < fb->height;
}

static void fb_fill_rect(const mp_obj_framebuf_t *fb, mp_int_t x, mp_int_t y, mp_int_t w, mp_int_t h, uint32_t c) {
    if (w < 1 || h < 1 || x + w <= 0 || y + h <= 0 || x >= fb->width || y >= fb->height) {
        return;
    }
    mp_int_t x1 = MIN(fb->width, x + w), y1 = MIN(fb->height, y + h);
    x = MAX(x, 0);
    y = MAX(y, 0);
    for (mp_int_t yy = y; yy < y1; ++yy) {
        for (mp_int_t xx = x; xx < x1; ++xx) {
            fb_set(fb, xx, yy, c);
        }
    }
}

static mp_obj_t framebuf_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 4, 5, false);
    mp_obj_framebuf_t *self = mp_obj_malloc(mp_obj_framebuf_t, type);
    self->buf_obj = args[0];
    self->width = mp_obj_get_int(args[1]);
    self->height = mp_obj_get_int(args[2]);
    mp_int_t fmt = mp_obj_get_int(args[3]);
    self->stride = n_args > 4 && args[4] != mp_const_none ? mp_obj_get_int(args[4]) : self->width;
    if (self->width < 1 || self->height < 1 || self->stride < self->width || fmt < 0 || fmt > FMT_GS8) {
        mp_raise_ValueError(NULL);
    }
    self->format = (uint8_t)fmt;
    size_t bits_per_pixel;
    switch (fmt) {
        case FMT_MONO_HLSB:
        case FMT_MONO_HMSB:
            self->stride = (self->stride + 7) & ~7;
            bits_per_pixel = 1;
            break;
        case FMT_GS2_HMSB:
            self->stride = (self->stride + 3) & ~3;
            bits_per_pixel = 2;
            break;
        case FMT_GS4_HMSB:
            self->stride = (self->stride + 1) & ~1;
            bits_per_pixel = 4;
            break;
        case FMT_RGB565:
            bits_per_pixel = 16;
            break;
        case FMT_GS8:
            bits_per_pixel = 8;
            break;
        default: // MONO_VLSB: rows of 8 pixels
            bits_per_pixel = 1;
            break;
    }
    size_t need = fmt == FMT_MONO_VLSB ? (size_t)((self->height + 7) >> 3) * self->stride
        : ((size_t)self->stride * self->height * bits_per_pixel + 7) / 8;
    mp_buffer_info_t bufinfo;
    mp_get_buffer_raise(args[0], &bufinfo, MP_BUFFER_WRITE);
    if (bufinfo.len < need) {
        mp_raise_ValueError(NULL);
    }
    self->buf = bufinfo.buf;
    return MP_OBJ_FROM_PTR(self);
}

static mp_int_t framebuf_get_buffer(mp_obj_t self_in, mp_buffer_info_t *bufinfo, mp_uint_t flags) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(self_in);
    return mp_get_buffer(self->buf_obj, bufinfo, flags) ? 0 : 1;
}

static mp_obj_t framebuf_fill(mp_obj_t self_in, mp_obj_t c_in) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(self_in);
    fb_fill_rect(self, 0, 0, self->width, self->height, mp_obj_get_int_truncated(c_in));
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(framebuf_fill_obj, framebuf_fill);

// args: self, then n ints
static void get_ints(const mp_obj_t *args, size_t n, mp_int_t *out) {
    for (size_t i = 0; i < n; ++i) {
        out[i] = mp_obj_get_int(args[i + 1]);
    }
}

static mp_obj_t framebuf_fill_rect(size_t n_args, const mp_obj_t *args) {
    mp_int_t a[5];
    get_ints(args, 5, a);
    fb_fill_rect(MP_OBJ_TO_PTR(args[0]), a[0], a[1], a[2], a[3], a[4]);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_fill_rect_obj, 6, 6, framebuf_fill_rect);

static mp_obj_t framebuf_pixel(size_t n_args, const mp_obj_t *args) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(args[0]);
    mp_int_t x = mp_obj_get_int(args[1]), y = mp_obj_get_int(args[2]);
    if (!fb_inside(self, x, y)) {
        return mp_const_none;
    }
    if (n_args == 3) {
        return MP_OBJ_NEW_SMALL_INT(fb_get(self, x, y));
    }
    fb_set(self, x, y, mp_obj_get_int_truncated(args[3]));
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_pixel_obj, 3, 4, framebuf_pixel);

static mp_obj_t framebuf_hline(size_t n_args, const mp_obj_t *args) {
    mp_int_t a[4];
    get_ints(args, 4, a);
    fb_fill_rect(MP_OBJ_TO_PTR(args[0]), a[0], a[1], a[2], 1, a[3]);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_hline_obj, 5, 5, framebuf_hline);

static mp_obj_t framebuf_vline(size_t n_args, const mp_obj_t *args) {
    mp_int_t a[4];
    get_ints(args, 4, a);
    fb_fill_rect(MP_OBJ_TO_PTR(args[0]), a[0], a[1], 1, a[2], a[3]);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_vline_obj, 5, 5, framebuf_vline);

static mp_obj_t framebuf_rect(size_t n_args, const mp_obj_t *args) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(args[0]);
    mp_int_t a[5];
    get_ints(args, 5, a);
    mp_int_t x = a[0], y = a[1], w = a[2], h = a[3], c = a[4];
    if (n_args > 6 && mp_obj_is_true(args[6])) {
        fb_fill_rect(self, x, y, w, h, c);
    } else {
        fb_fill_rect(self, x, y, w, 1, c);
        fb_fill_rect(self, x, y + h - 1, w, 1, c);
        fb_fill_rect(self, x, y, 1, h, c);
        fb_fill_rect(self, x + w - 1, y, 1, h, c);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_rect_obj, 6, 7, framebuf_rect);

// Bresenham, stepping along the major axis; the error term decides the minor-axis steps.
static mp_obj_t framebuf_line(size_t n_args, const mp_obj_t *args) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(args[0]);
    mp_int_t a[5];
    get_ints(args, 5, a);
    mp_int_t x0 = a[0], y0 = a[1], x1 = a[2], y1 = a[3], c = a[4];
    mp_int_t dx = x1 - x0, dy = y1 - y0;
    mp_int_t sx = dx > 0 ? 1 : -1, sy = dy > 0 ? 1 : -1;
    dx = dx < 0 ? -dx : dx;
    dy = dy < 0 ? -dy : dy;
    bool steep = dy > dx;
    if (steep) { // walk along y: swap the roles of the axes
        mp_int_t t = x0; x0 = y0; y0 = t;
        t = dx; dx = dy; dy = t;
        t = sx; sx = sy; sy = t;
    }
    mp_int_t e = 2 * dy - dx;
    for (mp_int_t i = 0; i < dx; ++i) {
        mp_int_t px = steep ? y0 : x0, py = steep ? x0 : y0;
        if (fb_inside(self, px, py)) {
            fb_set(self, px, py, c);
        }
        while (e >= 0) {
            y0 += sy;
            e -= 2 * dx;
        }
        x0 += sx;
        e += 2 * dy;
    }
    if (fb_inside(self, x1, y1)) { // the end point
        fb_set(self, x1, y1, c);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_line_obj, 6, 6, framebuf_line);

// The string's bytes are drawn 8 pixels apart; bytes outside 32..126 use glyph 127; NUL ends
// the text.  Only the set pixels of a glyph are drawn.
static mp_obj_t framebuf_text(size_t n_args, const mp_obj_t *args) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(args[0]);
    const char *s = mp_obj_str_get_str(args[1]);
    mp_int_t x = mp_obj_get_int(args[2]), y = mp_obj_get_int(args[3]);
    mp_int_t c = n_args > 4 ? mp_obj_get_int(args[4]) : 1;
    for (; *s; ++s, x += 8) {
        unsigned ch = (uint8_t)*s;
        if (ch < TP_FONT8X8_FIRST || ch > TP_FONT8X8_LAST) {
            ch = TP_FONT8X8_LAST;
        }
        const uint8_t *glyph = &tp_font8x8[(ch - TP_FONT8X8_FIRST) * 8];
        for (int col = 0; col < 8; ++col) {
            for (int row = 0; row < 8; ++row) {
                if ((glyph[col] >> row) & 1 && fb_inside(self, x + col, y + row)) {
                    fb_set(self, x + col, y + row, c);
                }
            }
        }
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_text_obj, 4, 5, framebuf_text);

// Moves the contents by (dx, dy); the uncovered strip keeps its old pixels.
static mp_obj_t framebuf_scroll(mp_obj_t self_in, mp_obj_t dx_in, mp_obj_t dy_in) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(self_in);
    mp_int_t dx = mp_obj_get_int(dx_in), dy = mp_obj_get_int(dy_in);
    if (dx >= self->width || -dx >= self->width || dy >= self->height || -dy >= self->height) {
        return mp_const_none;
    }
    for (mp_int_t j = 0; j < self->height - (dy < 0 ? -dy : dy); ++j) {
        mp_int_t y = dy > 0 ? self->height - 1 - j : j; // destination row, away from the source
        for (mp_int_t i = 0; i < self->width - (dx < 0 ? -dx : dx); ++i) {
            mp_int_t x = dx > 0 ? self->width - 1 - i : i;
            fb_set(self, x, y, fb_get(self, x - dx, y - dy));
        }
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_3(framebuf_scroll_obj, framebuf_scroll);

// blit(source, x, y[, key[, palette]]): source is a FrameBuffer; pixels equal to key are
// skipped; palette (a FrameBuffer) maps source colour c to palette.pixel(c, 0).
static mp_obj_t framebuf_blit(size_t n_args, const mp_obj_t *args) {
    mp_obj_framebuf_t *self = MP_OBJ_TO_PTR(args[0]);
    if (!mp_obj_is_type(args[1], &mp_type_framebuf)) {
        mp_raise_TypeError(MP_ERROR_TEXT("source must be a FrameBuffer"));
    }
    mp_obj_framebuf_t *src = MP_OBJ_TO_PTR(args[1]);
    mp_int_t x = mp_obj_get_int(args[2]), y = mp_obj_get_int(args[3]);
    mp_int_t key = n_args > 4 ? mp_obj_get_int(args[4]) : -1;
    mp_obj_framebuf_t *pal = NULL;
    if (n_args > 5 && args[5] != mp_const_none) {
        if (!mp_obj_is_type(args[5], &mp_type_framebuf)) {
            mp_raise_TypeError(MP_ERROR_TEXT("palette must be a FrameBuffer"));
        }
        pal = MP_OBJ_TO_PTR(args[5]);
    }
    for (mp_int_t sy = 0; sy < src->height; ++sy) {
        for (mp_int_t sx = 0; sx < src->width; ++sx) {
            if (!fb_inside(self, x + sx, y + sy)) {
                continue;
            }
            uint32_t c = fb_get(src, sx, sy);
            if ((mp_int_t)c == key) {
                continue;
            }
            if (pal != NULL) {
                c = fb_get(pal, (mp_int_t)c < pal->width ? (mp_int_t)c : pal->width - 1, 0);
            }
            fb_set(self, x + sx, y + sy, c);
        }
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(framebuf_blit_obj, 4, 6, framebuf_blit);

static const mp_rom_map_elem_t framebuf_locals_table[] = {
    { MP_ROM_QSTR(MP_QSTR_fill), MP_ROM_PTR(&framebuf_fill_obj) },
    { MP_ROM_QSTR(MP_QSTR_fill_rect), MP_ROM_PTR(&framebuf_fill_rect_obj) },
    { MP_ROM_QSTR(MP_QSTR_pixel), MP_ROM_PTR(&framebuf_pixel_obj) },
    { MP_ROM_QSTR(MP_QSTR_hline), MP_ROM_PTR(&framebuf_hline_obj) },
    { MP_ROM_QSTR(MP_QSTR_vline), MP_ROM_PTR(&framebuf_vline_obj) },
    { MP_ROM_QSTR(MP_QSTR_rect), MP_ROM_PTR(&framebuf_rect_obj) },
    { MP_ROM_QSTR(MP_QSTR_line), MP_ROM_PTR(&framebuf_line_obj) },
    { MP_ROM_QSTR(MP_QSTR_text), MP_ROM_PTR(&framebuf_text_obj) },
    { MP_ROM_QSTR(MP_QSTR_scroll), MP_ROM_PTR(&framebuf_scroll_obj) },
    { MP_ROM_QSTR(MP_QSTR_blit), MP_ROM_PTR(&framebuf_blit_obj) },
};
static MP_DEFINE_CONST_DICT(framebuf_locals, framebuf_locals_table);

static MP_DEFINE_CONST_OBJ_TYPE(
    mp_type_framebuf,
    MP_QSTR_FrameBuffer,
    MP_TYPE_FLAG_NONE,
    make_new, framebuf_make_new,
    buffer, framebuf_get_buffer,
    locals_dict, &framebuf_locals
    );

static const mp_rom_map_elem_t mp_module_framebuf_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_framebuf) },
    { MP_ROM_QSTR(MP_QSTR_FrameBuffer), MP_ROM_PTR(&mp_type_framebuf) },
    { MP_ROM_QSTR(MP_QSTR_MVLSB), MP_ROM_INT(FMT_MONO_VLSB) },
    { MP_ROM_QSTR(MP_QSTR_MONO_VLSB), MP_ROM_INT(FMT_MONO_VLSB) },
    { MP_ROM_QSTR(MP_QSTR_RGB565), MP_ROM_INT(FMT_RGB565) },
    { MP_ROM_QSTR(MP_QSTR_GS2_HMSB), MP_ROM_INT(FMT_GS2_HMSB) },
    { MP_ROM_QSTR(MP_QSTR_GS4_HMSB), MP_ROM_INT(FMT_GS4_HMSB) },
    { MP_ROM_QSTR(MP_QSTR_GS8), MP_ROM_INT(FMT_GS8) },
    { MP_ROM_QSTR(MP_QSTR_MONO_HLSB), MP_ROM_INT(FMT_MONO_HLSB) },
    { MP_ROM_QSTR(MP_QSTR_MONO_HMSB), MP_ROM_INT(FMT_MONO_HMSB) },
};
static MP_DEFINE_CONST_DICT(mp_module_framebuf_globals, mp_module_framebuf_globals_table);

const mp_obj_module_t mp_module_framebuf = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&mp_module_framebuf_globals,
};

MP_REGISTER_MODULE(MP_QSTR_framebuf, mp_module_framebuf);

#endif // MICROPY_PY_FRAMEBUF && TP_HAVE_FONT
