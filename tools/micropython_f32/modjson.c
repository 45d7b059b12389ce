// trackpilot f32 port: `json` module (dump, dumps, load, loads) with the behaviour of
// MicroPython's json:
// - dumps/dump use the core's JSON printing (PRINT_JSON, enabled by MICROPY_PY_JSON), so the
//   output is byte for byte what MicroPython prints, incl. the keyword-only `separators`.
// - loads/load accept what MicroPython's parser accepts: it is lenient (',' and ':' are
//   skipped like whitespace, any closing bracket closes the innermost container, a dict key
//   without a value is dropped) and raises ValueError("syntax error in JSON") otherwise.
//   Numbers are scanned as the characters 0-9 + - . e E and converted by the core's number
//   parser (ValueError on a malformed number).
#include <string.h>

#include "py/runtime.h"
#include "py/objlist.h"
#include "py/objstr.h"
#include "py/parsenum.h"
#include "py/stream.h"
#include "py/unicode.h"

#if MICROPY_PY_JSON

enum { DUMP_ARG_separators };
static const mp_arg_t dump_allowed_args[] = {
    { MP_QSTR_separators, MP_ARG_KW_ONLY | MP_ARG_OBJ, {.u_rom_obj = MP_ROM_NONE} },
};

static void json_dump_to(mp_print_ext_t *print_ext, mp_obj_t obj, mp_obj_t separators) {
    print_ext->item_separator = ", ";
    print_ext->key_separator = ": ";
    if (separators != mp_const_none) {
        size_t n;
        mp_obj_t *items;
        mp_obj_get_array(separators, &n, &items);
        if (n != 2) {
            mp_raise_ValueError(MP_ERROR_TEXT("separators must be a 2-sequence"));
        }
        print_ext->item_separator = mp_obj_str_get_str(items[0]);
        print_ext->key_separator = mp_obj_str_get_str(items[1]);
    }
    mp_obj_print_helper(&print_ext->base, obj, PRINT_JSON);
}

static mp_obj_t mod_json_dumps(size_t n_args, const mp_obj_t *pos_args, mp_map_t *kw_args) {
    mp_arg_val_t args[MP_ARRAY_SIZE(dump_allowed_args)];
    mp_arg_parse_all(n_args - 1, pos_args + 1, kw_args, MP_ARRAY_SIZE(dump_allowed_args), dump_allowed_args, args);
    vstr_t vstr;
    mp_print_ext_t print_ext;
    vstr_init_print(&vstr, 8, &print_ext.base);
    json_dump_to(&print_ext, pos_args[0], args[DUMP_ARG_separators].u_obj);
    return mp_obj_new_str_from_utf8_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_KW(mod_json_dumps_obj, 1, mod_json_dumps);

static mp_obj_t mod_json_dump(size_t n_args, const mp_obj_t *pos_args, mp_map_t *kw_args) {
    mp_arg_val_t args[MP_ARRAY_SIZE(dump_allowed_args)];
    mp_arg_parse_all(n_args - 2, pos_args + 2, kw_args, MP_ARRAY_SIZE(dump_allowed_args), dump_allowed_args, args);
    mp_get_stream_raise(pos_args[1], MP_STREAM_OP_WRITE);
    mp_print_ext_t print_ext;
    print_ext.base.data = MP_OBJ_TO_PTR(pos_args[1]);
    print_ext.base.print_strn = mp_stream_write_adaptor;
    json_dump_to(&print_ext, pos_args[0], args[DUMP_ARG_separators].u_obj);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_KW(mod_json_dump_obj, 2, mod_json_dump);

static MP_NORETURN void json_syntax_error(void) {
    mp_raise_ValueError(MP_ERROR_TEXT("syntax error in JSON"));
}

// Consumes `word` (the rest of true/false/null) or raises.
static const byte *json_expect(const byte *s, const byte *top, const char *word) {
    size_t n = strlen(word);
    if ((size_t)(top - s) < n || memcmp(s, word, n) != 0) {
        json_syntax_error();
    }
    return s + n;
}

// s points after the opening quote; returns the position after the closing quote.
static const byte *json_string(const byte *s, const byte *top, vstr_t *vstr, mp_obj_t *out) {
    vstr_reset(vstr);
    for (;;) {
        if (s >= top) {
            json_syntax_error();
        }
        byte c = *s++;
        if (c == '"') {
            break;
        }
        if (c == '\\') {
            if (s >= top) {
                json_syntax_error();
            }
            c = *s++;
            switch (c) {
                case 'b':
                    c = '\b';
                    break;
                case 'f':
                    c = '\f';
                    break;
                case 'n':
                    c = '\n';
                    break;
                case 'r':
                    c = '\r';
                    break;
                case 't':
                    c = '\t';
                    break;
                case 'u': {
                    if (top - s < 4) {
                        json_syntax_error();
                    }
                    // Four hex digits (not validated, as in MicroPython).
                    unichar cp = 0;
                    for (int i = 0; i < 4; ++i) {
                        byte h = (byte)((*s++ | 0x20) - '0');
                        if (h > 9) {
                            h -= ('a' - '0') - 10;
                        }
                        cp = (cp << 4) | h;
                    }
                    vstr_add_char(vstr, cp);
                    continue;
                }
                default: // \" \\ \/ and any other character stand for themselves
                    break;
            }
        }
        vstr_add_byte(vstr, c);
    }
    *out = mp_obj_new_str(vstr->buf, vstr->len);
    return s;
}

static mp_obj_t json_parse(const byte *s, const byte *top) {
    // Open containers, two entries per level: the container and (for a dict) the key that
    // waits for its value, MP_OBJ_NULL if none.
    mp_obj_list_t *stack = MP_OBJ_TO_PTR(mp_obj_new_list(0, NULL));
    mp_obj_t result = MP_OBJ_NULL;
    vstr_t vstr;
    vstr_init(&vstr, 8);
    for (;;) {
        if (s >= top) {
            json_syntax_error();
        }
        byte c = *s++;
        mp_obj_t next;
        bool enter = false;
        switch (c) {
            case ' ':
            case '\t':
            case '\n':
            case '\r':
            case ',':
            case ':':
                continue;
            case 'n':
                s = json_expect(s, top, "ull");
                next = mp_const_none;
                break;
            case 't':
                s = json_expect(s, top, "rue");
                next = mp_const_true;
                break;
            case 'f':
                s = json_expect(s, top, "alse");
                next = mp_const_false;
                break;
            case '"':
                s = json_string(s, top, &vstr, &next);
                break;
            case '-':
            case '0': case '1': case '2': case '3': case '4':
            case '5': case '6': case '7': case '8': case '9': {
                const byte *start = s - 1;
                bool is_float = false;
                while (s < top && ((*s >= '0' && *s <= '9') || *s == '-' || *s == '+'
                                   || *s == '.' || *s == 'e' || *s == 'E')) {
                    if (*s == '.' || *s == 'e' || *s == 'E') {
                        is_float = true;
                    }
                    ++s;
                }
                if (is_float) {
                    next = mp_parse_num_float((const char *)start, s - start, false, NULL);
                } else {
                    next = mp_parse_num_integer((const char *)start, s - start, 10, NULL);
                }
                break;
            }
            case '[':
                next = mp_obj_new_list(0, NULL);
                enter = true;
                break;
            case '{':
                next = mp_obj_new_dict(0);
                enter = true;
                break;
            case ']':
            case '}':
                if (stack->len == 0) {
                    json_syntax_error();
                }
                stack->len -= 2;
                stack->items[stack->len] = MP_OBJ_NULL;
                stack->items[stack->len + 1] = MP_OBJ_NULL;
                if (stack->len == 0) {
                    goto done;
                }
                continue;
            default:
                json_syntax_error();
        }
        if (stack->len == 0) {
            result = next;
            if (!enter) {
                goto done;
            }
        } else {
            mp_obj_t container = stack->items[stack->len - 2];
            if (mp_obj_is_type(container, &mp_type_list)) {
                mp_obj_list_append(container, next);
            } else if (stack->items[stack->len - 1] == MP_OBJ_NULL) {
                if (enter) {
                    json_syntax_error(); // a container can't be a key
                }
                stack->items[stack->len - 1] = next;
                continue;
            } else {
                mp_obj_dict_store(container, stack->items[stack->len - 1], next);
                stack->items[stack->len - 1] = MP_OBJ_NULL;
            }
        }
        if (enter) {
            mp_obj_list_append(MP_OBJ_FROM_PTR(stack), next);
            mp_obj_list_append(MP_OBJ_FROM_PTR(stack), MP_OBJ_NULL);
        }
    }
done:
    vstr_clear(&vstr);
    while (s < top && unichar_isspace(*s)) {
        ++s;
    }
    if (s < top) {
        json_syntax_error();
    }
    return result;
}

static mp_obj_t mod_json_loads(mp_obj_t data) {
    mp_buffer_info_t buf;
    mp_get_buffer_raise(data, &buf, MP_BUFFER_READ);
    return json_parse(buf.buf, (const byte *)buf.buf + buf.len);
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_json_loads_obj, mod_json_loads);

static mp_obj_t mod_json_load(mp_obj_t stream) {
    mp_obj_t dest[2];
    mp_load_method(stream, MP_QSTR_read, dest);
    return mod_json_loads(mp_call_method_n_kw(0, 0, dest));
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_json_load_obj, mod_json_load);

static const mp_rom_map_elem_t mp_module_json_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_json) },
    { MP_ROM_QSTR(MP_QSTR_dump), MP_ROM_PTR(&mod_json_dump_obj) },
    { MP_ROM_QSTR(MP_QSTR_dumps), MP_ROM_PTR(&mod_json_dumps_obj) },
    { MP_ROM_QSTR(MP_QSTR_load), MP_ROM_PTR(&mod_json_load_obj) },
    { MP_ROM_QSTR(MP_QSTR_loads), MP_ROM_PTR(&mod_json_loads_obj) },
};
static MP_DEFINE_CONST_DICT(mp_module_json_globals, mp_module_json_globals_table);

const mp_obj_module_t mp_module_json = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&mp_module_json_globals,
};

MP_REGISTER_EXTENSIBLE_MODULE(MP_QSTR_json, mp_module_json);

#endif // MICROPY_PY_JSON
