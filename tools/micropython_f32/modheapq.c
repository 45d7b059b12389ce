// trackpilot f32 port: `heapq` module (heappush, heappop, heapify on a list, min-heap by `<`).
#include "py/runtime.h"
#include "py/objlist.h"

#if MICROPY_PY_HEAPQ

static mp_obj_list_t *heap_list(mp_obj_t heap_in) {
    if (!mp_obj_is_type(heap_in, &mp_type_list)) {
        mp_raise_TypeError(MP_ERROR_TEXT("heap must be a list"));
    }
    return MP_OBJ_TO_PTR(heap_in);
}

static bool heap_less(mp_obj_t a, mp_obj_t b) {
    return mp_obj_is_true(mp_binary_op(MP_BINARY_OP_LESS, a, b));
}

// Move the item at pos up towards the root (start) while it is smaller than its parent.
static void heap_sift_up(mp_obj_t *items, size_t start, size_t pos) {
    mp_obj_t item = items[pos];
    while (pos > start) {
        size_t parent = (pos - 1) / 2;
        if (!heap_less(item, items[parent])) {
            break;
        }
        items[pos] = items[parent];
        pos = parent;
    }
    items[pos] = item;
}

// Restore the heap below pos: move the smaller child up until a leaf, then sift the item up.
static void heap_sift_down(mp_obj_t *items, size_t len, size_t pos) {
    size_t start = pos;
    mp_obj_t item = items[pos];
    size_t child = 2 * pos + 1;
    while (child < len) {
        if (child + 1 < len && !heap_less(items[child], items[child + 1])) {
            child += 1;
        }
        items[pos] = items[child];
        pos = child;
        child = 2 * pos + 1;
    }
    items[pos] = item;
    heap_sift_up(items, start, pos);
}

static mp_obj_t mod_heapq_heappush(mp_obj_t heap_in, mp_obj_t item) {
    mp_obj_list_t *heap = heap_list(heap_in);
    mp_obj_list_append(heap_in, item);
    heap_sift_up(heap->items, 0, heap->len - 1);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(mod_heapq_heappush_obj, mod_heapq_heappush);

static mp_obj_t mod_heapq_heappop(mp_obj_t heap_in) {
    mp_obj_list_t *heap = heap_list(heap_in);
    if (heap->len == 0) {
        mp_raise_msg(&mp_type_IndexError, MP_ERROR_TEXT("empty heap"));
    }
    mp_obj_t top = heap->items[0];
    heap->len -= 1;
    heap->items[0] = heap->items[heap->len];
    heap->items[heap->len] = MP_OBJ_NULL; // let the GC reclaim it
    if (heap->len > 0) {
        heap_sift_down(heap->items, heap->len, 0);
    }
    return top;
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_heapq_heappop_obj, mod_heapq_heappop);

static mp_obj_t mod_heapq_heapify(mp_obj_t heap_in) {
    mp_obj_list_t *heap = heap_list(heap_in);
    for (size_t i = heap->len / 2; i-- > 0;) {
        heap_sift_down(heap->items, heap->len, i);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_heapq_heapify_obj, mod_heapq_heapify);

static const mp_rom_map_elem_t mp_module_heapq_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_heapq) },
    { MP_ROM_QSTR(MP_QSTR_heappush), MP_ROM_PTR(&mod_heapq_heappush_obj) },
    { MP_ROM_QSTR(MP_QSTR_heappop), MP_ROM_PTR(&mod_heapq_heappop_obj) },
    { MP_ROM_QSTR(MP_QSTR_heapify), MP_ROM_PTR(&mod_heapq_heapify_obj) },
};
static MP_DEFINE_CONST_DICT(mp_module_heapq_globals, mp_module_heapq_globals_table);

const mp_obj_module_t mp_module_heapq = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&mp_module_heapq_globals,
};

MP_REGISTER_EXTENSIBLE_MODULE(MP_QSTR_heapq, mp_module_heapq);

#endif // MICROPY_PY_HEAPQ
