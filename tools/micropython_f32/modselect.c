// trackpilot f32 port: `select.poll`, the part of MicroPython's select module that asyncio and the
// firmware use (the real one lives in extmod/, which the sdist does not ship).
//
// A poll object holds (object, event mask) pairs. Readiness is asked of each object through the
// stream protocol (MP_STREAM_POLL ioctl): Python io.IOBase subclasses answer with their ioctl()
// method, files opened here (fileio.c) ask poll(2) about their descriptor. poll(timeout_ms) checks
// every object, and if none is ready sleeps 1 ms at a time until the timeout (-1: forever).
// ipoll() is poll() returning the same list; flags are ignored (no one-shot mode).
#include <errno.h>
#include <string.h>

#include "py/mperrno.h"
#include "py/mphal.h"
#include "py/obj.h"
#include "py/objlist.h"
#include "py/runtime.h"
#include "py/stream.h"


// Same values as MicroPython's select module (and the stream protocol's MP_STREAM_POLL_*).
#define POLLIN (0x0001)
#define POLLOUT (0x0004)
#define POLLERR (0x0008)
#define POLLHUP (0x0010)

typedef struct _poll_obj_t {
    mp_obj_base_t base;
    mp_obj_t entries; // list of 2-item lists [obj, mask]
} poll_obj_t;

static mp_obj_t *poll_find(poll_obj_t *self, mp_obj_t obj, size_t *index) {
    size_t n;
    mp_obj_t *items;
    mp_obj_list_get(self->entries, &n, &items);
    for (size_t i = 0; i < n; ++i) {
        mp_obj_t *pair;
        size_t pn;
        mp_obj_list_get(items[i], &pn, &pair);
        if (pair[0] == obj) {
            if (index) {
                *index = i;
            }
            return pair;
        }
    }
    return NULL;
}

// The events of obj that are ready now (of those in mask, plus errors).
static mp_uint_t poll_one(mp_obj_t obj, mp_uint_t mask) {
    const mp_stream_p_t *stream = mp_get_stream_raise(obj, MP_STREAM_OP_IOCTL);
    int errcode;
    mp_uint_t ret = stream->ioctl(obj, MP_STREAM_POLL, mask, &errcode);
    if (ret == MP_STREAM_ERROR) {
        return POLLERR;
    }
    return ret & (mask | POLLERR | POLLHUP);
}

static mp_obj_t poll_register(size_t n_args, const mp_obj_t *args) {
    poll_obj_t *self = MP_OBJ_TO_PTR(args[0]);
    mp_uint_t mask = n_args > 2 ? mp_obj_get_int(args[2]) : (POLLIN | POLLOUT);
    mp_get_stream_raise(args[1], MP_STREAM_OP_IOCTL); // only streams can be polled
    mp_obj_t *pair = poll_find(self, args[1], NULL);
    if (pair != NULL) {
        pair[1] = MP_OBJ_NEW_SMALL_INT(mask);
    } else {
        mp_obj_t item[2] = {args[1], MP_OBJ_NEW_SMALL_INT(mask)};
        mp_obj_list_append(self->entries, mp_obj_new_list(2, item));
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(poll_register_obj, 2, 3, poll_register);

static mp_obj_t poll_unregister(mp_obj_t self_in, mp_obj_t obj) {
    poll_obj_t *self = MP_OBJ_TO_PTR(self_in);
    size_t index;
    if (poll_find(self, obj, &index) != NULL) {
        mp_obj_list_t *list = MP_OBJ_TO_PTR(self->entries);
        memmove(&list->items[index], &list->items[index + 1], (list->len - index - 1) * sizeof(mp_obj_t));
        list->len -= 1;
        list->items[list->len] = MP_OBJ_NULL;
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(poll_unregister_obj, poll_unregister);

static mp_obj_t poll_modify(mp_obj_t self_in, mp_obj_t obj, mp_obj_t mask_in) {
    poll_obj_t *self = MP_OBJ_TO_PTR(self_in);
    mp_obj_t *pair = poll_find(self, obj, NULL);
    if (pair == NULL) {
        mp_raise_OSError(MP_ENOENT);
    }
    pair[1] = MP_OBJ_NEW_SMALL_INT(mp_obj_get_int(mask_in));
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_3(poll_modify_obj, poll_modify);

static mp_obj_t poll_poll(size_t n_args, const mp_obj_t *args) {
    poll_obj_t *self = MP_OBJ_TO_PTR(args[0]);
    mp_int_t timeout_ms = -1;
    if (n_args > 1 && args[1] != mp_const_none) {
        timeout_ms = mp_obj_get_int(args[1]);
    }
    mp_uint_t start_ms = mp_hal_ticks_ms();
    for (;;) {
        mp_obj_t result = mp_obj_new_list(0, NULL);
        size_t n;
        mp_obj_t *items;
        mp_obj_list_get(self->entries, &n, &items);
        for (size_t i = 0; i < n; ++i) {
            mp_obj_t *pair;
            size_t pn;
            mp_obj_list_get(items[i], &pn, &pair);
            mp_uint_t ready = poll_one(pair[0], MP_OBJ_SMALL_INT_VALUE(pair[1]));
            if (ready) {
                mp_obj_t tuple[2] = {pair[0], MP_OBJ_NEW_SMALL_INT(ready)};
                mp_obj_list_append(result, mp_obj_new_tuple(2, tuple));
            }
            mp_obj_list_get(self->entries, &n, &items); // an ioctl may have changed the list
        }
        mp_obj_list_get(result, &n, &items);
        if (n > 0 || timeout_ms == 0
            || (timeout_ms > 0 && (mp_int_t)(mp_hal_ticks_ms() - start_ms) >= timeout_ms)) {
            return result;
        }
        mp_hal_delay_ms(1);
        mp_handle_pending(true);
    }
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(poll_poll_obj, 1, 3, poll_poll);

static const mp_rom_map_elem_t poll_locals_dict_table[] = {
    { MP_ROM_QSTR(MP_QSTR_register), MP_ROM_PTR(&poll_register_obj) },
    { MP_ROM_QSTR(MP_QSTR_unregister), MP_ROM_PTR(&poll_unregister_obj) },
    { MP_ROM_QSTR(MP_QSTR_modify), MP_ROM_PTR(&poll_modify_obj) },
    { MP_ROM_QSTR(MP_QSTR_poll), MP_ROM_PTR(&poll_poll_obj) },
    { MP_ROM_QSTR(MP_QSTR_ipoll), MP_ROM_PTR(&poll_poll_obj) },
};
static MP_DEFINE_CONST_DICT(poll_locals_dict, poll_locals_dict_table);

static MP_DEFINE_CONST_OBJ_TYPE(
    mp_type_poll,
    MP_QSTR_poll,
    MP_TYPE_FLAG_NONE,
    locals_dict, &poll_locals_dict
    );

static mp_obj_t select_poll(void) {
    poll_obj_t *self = mp_obj_malloc(poll_obj_t, &mp_type_poll);
    self->entries = mp_obj_new_list(0, NULL);
    return MP_OBJ_FROM_PTR(self);
}
static MP_DEFINE_CONST_FUN_OBJ_0(select_poll_obj, select_poll);

static const mp_rom_map_elem_t select_module_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_select) },
    { MP_ROM_QSTR(MP_QSTR_poll), MP_ROM_PTR(&select_poll_obj) },
    { MP_ROM_QSTR(MP_QSTR_POLLIN), MP_ROM_INT(POLLIN) },
    { MP_ROM_QSTR(MP_QSTR_POLLOUT), MP_ROM_INT(POLLOUT) },
    { MP_ROM_QSTR(MP_QSTR_POLLERR), MP_ROM_INT(POLLERR) },
    { MP_ROM_QSTR(MP_QSTR_POLLHUP), MP_ROM_INT(POLLHUP) },
};
static MP_DEFINE_CONST_DICT(select_module_globals, select_module_globals_table);

const mp_obj_module_t mp_module_select = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&select_module_globals,
};

MP_REGISTER_MODULE(MP_QSTR_select, mp_module_select);

