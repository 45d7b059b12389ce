// trackpilot f32 port: `gcinfo.info()`, the heap figures MicroPython's micropython.mem_info()
// prints, as numbers: (total, used, free, largest free block, largest used block), in bytes.
// Only in this host build (not on the ESP32): the benchmark's start-up heap table reads the
// largest free block here, because finding it by allocating can leave a stale pointer that
// pins the block it found.
#include <unistd.h>

#include "py/gc.h"
#include "py/runtime.h"

static mp_obj_t gcinfo_info(void) {
    gc_info_t info;
    gc_info(&info);
    mp_obj_t items[5] = {
        mp_obj_new_int_from_uint(info.total),
        mp_obj_new_int_from_uint(info.used),
        mp_obj_new_int_from_uint(info.free),
        mp_obj_new_int_from_uint(info.max_free * MICROPY_BYTES_PER_GC_BLOCK),
        mp_obj_new_int_from_uint(info.max_block * MICROPY_BYTES_PER_GC_BLOCK),
    };
    return mp_obj_new_tuple(5, items);
}
static MP_DEFINE_CONST_FUN_OBJ_0(gcinfo_info_obj, gcinfo_info);

// `gcinfo.loader()`: (bytes, modules) the core's loader has put on the heap for the modules frozen
// into the frozen-firmware build, which a real freeze keeps in flash (romfs.c); (0, 0) otherwise.
size_t romfs_loader_heap(size_t *modules);

static mp_obj_t gcinfo_loader(void) {
    size_t modules;
    size_t bytes = romfs_loader_heap(&modules);
    mp_obj_t items[2] = {mp_obj_new_int_from_uint(bytes), mp_obj_new_int_from_uint(modules)};
    return mp_obj_new_tuple(2, items);
}
static MP_DEFINE_CONST_FUN_OBJ_0(gcinfo_loader_obj, gcinfo_loader);

// `gcinfo.dump()`: the heap's block map (as micropython.mem_info(1) prints it) on stderr, for
// finding what splits the free heap; stdout is the simulator's protocol.
static void gcinfo_stderr_strn(void *env, const char *str, size_t len) {
    (void)env;
    ssize_t r = write(2, str, len);
    (void)r;
}
static const mp_print_t gcinfo_stderr_print = {NULL, gcinfo_stderr_strn};

static mp_obj_t gcinfo_dump(void) {
    gc_dump_alloc_table(&gcinfo_stderr_print);
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_0(gcinfo_dump_obj, gcinfo_dump);

// `gcinfo.collections()`: (collections, their CPU time in us, the longest in us) since start-up,
// counted in gc_collect (main.c); `gcinfo.collections(True)` also restarts the longest.
extern size_t gcinfo_n_collections;
extern uint64_t gcinfo_collect_cpu_ns;
extern uint64_t gcinfo_collect_cpu_max_ns;

static mp_obj_t gcinfo_collections(size_t n_args, const mp_obj_t *args) {
    mp_obj_t items[3] = {
        mp_obj_new_int_from_uint(gcinfo_n_collections),
        mp_obj_new_int_from_ull(gcinfo_collect_cpu_ns / 1000u),
        mp_obj_new_int_from_uint((size_t)(gcinfo_collect_cpu_max_ns / 1000u)),
    };
    if (n_args > 0 && mp_obj_is_true(args[0])) {
        gcinfo_collect_cpu_max_ns = 0;
    }
    return mp_obj_new_tuple(3, items);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(gcinfo_collections_obj, 0, 1, gcinfo_collections);

// `gcinfo.allocated()`: bytes allocated since start-up, freed or not (what gc.threshold counts:
// whole 16-byte blocks, a realloc that moves counted again), for allocation rates.
extern uint64_t gcinfo_blocks_before;

static mp_obj_t gcinfo_allocated(void) {
    return mp_obj_new_int_from_ull((gcinfo_blocks_before + MP_STATE_MEM(gc_alloc_amount)) * MICROPY_BYTES_PER_GC_BLOCK);
}
static MP_DEFINE_CONST_FUN_OBJ_0(gcinfo_allocated_obj, gcinfo_allocated);

static const mp_rom_map_elem_t gcinfo_module_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_gcinfo) },
    { MP_ROM_QSTR(MP_QSTR_info), MP_ROM_PTR(&gcinfo_info_obj) },
    { MP_ROM_QSTR(MP_QSTR_loader), MP_ROM_PTR(&gcinfo_loader_obj) },
    { MP_ROM_QSTR(MP_QSTR_dump), MP_ROM_PTR(&gcinfo_dump_obj) },
    { MP_ROM_QSTR(MP_QSTR_collections), MP_ROM_PTR(&gcinfo_collections_obj) },
    { MP_ROM_QSTR(MP_QSTR_allocated), MP_ROM_PTR(&gcinfo_allocated_obj) },
};
static MP_DEFINE_CONST_DICT(gcinfo_module_globals, gcinfo_module_globals_table);

const mp_obj_module_t mp_module_gcinfo = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&gcinfo_module_globals,
};

MP_REGISTER_MODULE(MP_QSTR_gcinfo, mp_module_gcinfo);
