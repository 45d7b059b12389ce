// trackpilot f32 port: `binascii` module (hexlify, unhexlify, a2b_base64, b2a_base64, crc32)
// with the behaviour of MicroPython's: lenient base64 decoding (characters outside the
// alphabet are skipped), ValueError for odd/non-hex input and for incorrect base64 padding.
#include "py/runtime.h"
#include "py/binary.h"
#include "py/objstr.h"

#if MICROPY_PY_BINASCII

static const char b64_alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static mp_obj_t mod_binascii_hexlify(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t buf;
    mp_get_buffer_raise(args[0], &buf, MP_BUFFER_READ);
    const char *sep = NULL;
    size_t sep_len = 0;
    if (n_args > 1 && args[1] != mp_const_none) {
        sep = mp_obj_str_get_data(args[1], &sep_len);
    }
    if (buf.len == 0) {
        return mp_const_empty_bytes;
    }
    vstr_t vstr;
    vstr_init(&vstr, buf.len * (2 + sep_len));
    const byte *in = buf.buf;
    for (size_t i = 0; i < buf.len; ++i) {
        if (i > 0 && sep_len > 0) {
            vstr_add_strn(&vstr, sep, sep_len);
        }
        vstr_add_byte(&vstr, "0123456789abcdef"[in[i] >> 4]);
        vstr_add_byte(&vstr, "0123456789abcdef"[in[i] & 15]);
    }
    return mp_obj_new_bytes_from_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(mod_binascii_hexlify_obj, 1, 2, mod_binascii_hexlify);

static int hex_value(byte c) {
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    c |= 0x20;
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

static mp_obj_t mod_binascii_unhexlify(mp_obj_t data) {
    mp_buffer_info_t buf;
    mp_get_buffer_raise(data, &buf, MP_BUFFER_READ);
    if (buf.len & 1) {
        mp_raise_ValueError(MP_ERROR_TEXT("odd-length string"));
    }
    vstr_t vstr;
    vstr_init(&vstr, buf.len / 2);
    const byte *in = buf.buf;
    for (size_t i = 0; i < buf.len; i += 2) {
        int hi = hex_value(in[i]);
        int lo = hex_value(in[i + 1]);
        if (hi < 0 || lo < 0) {
            mp_raise_ValueError(MP_ERROR_TEXT("non-hex digit"));
        }
        vstr_add_byte(&vstr, (byte)(hi << 4 | lo));
    }
    return mp_obj_new_bytes_from_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_binascii_unhexlify_obj, mod_binascii_unhexlify);

static int b64_value(byte c) {
    if (c >= 'A' && c <= 'Z') {
        return c - 'A';
    } else if (c >= 'a' && c <= 'z') {
        return c - 'a' + 26;
    } else if (c >= '0' && c <= '9') {
        return c - '0' + 52;
    } else if (c == '+') {
        return 62;
    } else if (c == '/') {
        return 63;
    }
    return -1;
}

// Decoding is a bit stream: alphabet characters add 6 bits each and every full 8 bits give a
// byte; other characters are skipped.  '=' ends the data when it completes a group (one '='
// after 3 data characters of a group, the second '=' after 2), otherwise it is ignored.
// Bits left over at the end mean the input was incorrectly padded.
static mp_obj_t mod_binascii_a2b_base64(mp_obj_t data) {
    mp_buffer_info_t buf;
    mp_get_buffer_raise(data, &buf, MP_BUFFER_READ);
    const byte *in = buf.buf;
    vstr_t vstr;
    vstr_init(&vstr, (buf.len / 4) * 3 + 1);
    uint32_t acc = 0;
    int nbits = 0; // bits in acc not yet output
    bool pad_seen = false; // a '=' since the last data character
    for (size_t i = 0; i < buf.len; ++i) {
        byte c = in[i];
        if (c == '=') {
            if (nbits == 2 || (nbits == 4 && pad_seen)) {
                nbits = 0;
                break;
            }
            pad_seen = true;
            continue;
        }
        int v = b64_value(c);
        if (v < 0) {
            continue;
        }
        pad_seen = false;
        acc = (acc << 6) | (uint32_t)v;
        nbits += 6;
        if (nbits >= 8) {
            nbits -= 8;
            vstr_add_byte(&vstr, (byte)(acc >> nbits));
        }
    }
    if (nbits != 0) {
        mp_raise_ValueError(MP_ERROR_TEXT("incorrect padding"));
    }
    return mp_obj_new_bytes_from_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_binascii_a2b_base64_obj, mod_binascii_a2b_base64);

static mp_obj_t mod_binascii_b2a_base64(size_t n_args, const mp_obj_t *pos_args, mp_map_t *kw_args) {
    enum { ARG_newline };
    static const mp_arg_t allowed_args[] = {
        { MP_QSTR_newline, MP_ARG_KW_ONLY | MP_ARG_BOOL, {.u_bool = true} },
    };
    mp_arg_val_t args[MP_ARRAY_SIZE(allowed_args)];
    mp_arg_parse_all(n_args - 1, pos_args + 1, kw_args, MP_ARRAY_SIZE(allowed_args), allowed_args, args);

    mp_buffer_info_t buf;
    mp_get_buffer_raise(pos_args[0], &buf, MP_BUFFER_READ);
    const byte *in = buf.buf;
    vstr_t vstr;
    vstr_init(&vstr, (buf.len + 2) / 3 * 4 + 1);
    size_t i = 0;
    for (; i + 3 <= buf.len; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16 | (uint32_t)in[i + 1] << 8 | in[i + 2];
        vstr_add_byte(&vstr, b64_alphabet[(v >> 18) & 63]);
        vstr_add_byte(&vstr, b64_alphabet[(v >> 12) & 63]);
        vstr_add_byte(&vstr, b64_alphabet[(v >> 6) & 63]);
        vstr_add_byte(&vstr, b64_alphabet[v & 63]);
    }
    size_t rest = buf.len - i;
    if (rest > 0) {
        uint32_t v = (uint32_t)in[i] << 16 | (rest == 2 ? (uint32_t)in[i + 1] << 8 : 0);
        vstr_add_byte(&vstr, b64_alphabet[(v >> 18) & 63]);
        vstr_add_byte(&vstr, b64_alphabet[(v >> 12) & 63]);
        vstr_add_byte(&vstr, rest == 2 ? b64_alphabet[(v >> 6) & 63] : '=');
        vstr_add_byte(&vstr, '=');
    }
    if (args[ARG_newline].u_bool) {
        vstr_add_byte(&vstr, '\n');
    }
    return mp_obj_new_bytes_from_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_KW(mod_binascii_b2a_base64_obj, 1, mod_binascii_b2a_base64);

// CRC-32 (IEEE 802.3, reflected polynomial 0xedb88320), bitwise.
static mp_obj_t mod_binascii_crc32(size_t n_args, const mp_obj_t *args) {
    mp_buffer_info_t buf;
    mp_get_buffer_raise(args[0], &buf, MP_BUFFER_READ);
    uint32_t crc = n_args > 1 ? (uint32_t)mp_obj_get_int_truncated(args[1]) : 0;
    crc = ~crc;
    const byte *in = buf.buf;
    for (size_t i = 0; i < buf.len; ++i) {
        crc ^= in[i];
        for (int b = 0; b < 8; ++b) {
            crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1)));
        }
    }
    return mp_obj_new_int_from_uint(~crc);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(mod_binascii_crc32_obj, 1, 2, mod_binascii_crc32);

static const mp_rom_map_elem_t mp_module_binascii_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_binascii) },
    { MP_ROM_QSTR(MP_QSTR_hexlify), MP_ROM_PTR(&mod_binascii_hexlify_obj) },
    { MP_ROM_QSTR(MP_QSTR_unhexlify), MP_ROM_PTR(&mod_binascii_unhexlify_obj) },
    { MP_ROM_QSTR(MP_QSTR_a2b_base64), MP_ROM_PTR(&mod_binascii_a2b_base64_obj) },
    { MP_ROM_QSTR(MP_QSTR_b2a_base64), MP_ROM_PTR(&mod_binascii_b2a_base64_obj) },
    { MP_ROM_QSTR(MP_QSTR_crc32), MP_ROM_PTR(&mod_binascii_crc32_obj) },
};
static MP_DEFINE_CONST_DICT(mp_module_binascii_globals, mp_module_binascii_globals_table);

const mp_obj_module_t mp_module_binascii = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&mp_module_binascii_globals,
};

MP_REGISTER_EXTENSIBLE_MODULE(MP_QSTR_binascii, mp_module_binascii);

#endif // MICROPY_PY_BINASCII
