// trackpilot f32 port: modules frozen into the binary as .mpy images in read-only memory (the
// "frozen firmware" build, build_micropython_f32.sh --frozen). They appear under the ".frozen"
// entry of sys.path, as on the ESP32, and are imported in place: the core's ROM reader
// (MICROPY_VFS_ROM) takes bytecode, strings and qstrs straight from the image instead of copying
// them to the heap, so like frozen bytecode on the board the code costs no RAM. (Not the same as
// mpy-tool's freezing: the function and module objects are still made on the heap at import.)
// Without TRACKPILOT_ROMFS the table is empty and every import reads files.
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include "py/builtin.h"
#include "py/gc.h"
#include "py/reader.h"
#include "py/runtime.h"

typedef struct {
    const char *path; // relative to ".frozen/", e.g. "trackpilot/app.mpy"
    const unsigned char *data;
    size_t len;
} romfs_entry_t;

#if TRACKPILOT_ROMFS
#include "trackpilot_romfs.h" // generated: romfs_entries[], romfs_count
#else
static const romfs_entry_t romfs_entries[1] = {{NULL, NULL, 0}};
static const size_t romfs_count = 0;
#endif

#define ROMFS_PREFIX ".frozen/"
#define ROMFS_PREFIX_LEN (sizeof(ROMFS_PREFIX) - 1)

size_t romfs_module_count(void) {
    return romfs_count;
}

// 0: not in the image, 1: a file, 2: a directory (a prefix of some file's path).
int romfs_stat(const char *path) {
    if (strncmp(path, ROMFS_PREFIX, ROMFS_PREFIX_LEN) != 0) {
        return 0;
    }
    path += ROMFS_PREFIX_LEN;
    size_t n = strlen(path);
    for (size_t i = 0; i < romfs_count; ++i) {
        const char *p = romfs_entries[i].path;
        if (strcmp(p, path) == 0) {
            return 1;
        }
        if (strncmp(p, path, n) == 0 && p[n] == '/') {
            return 2;
        }
    }
    return 0;
}

static const romfs_entry_t *romfs_find(const char *path) {
    if (strncmp(path, ROMFS_PREFIX, ROMFS_PREFIX_LEN) != 0) {
        return NULL;
    }
    path += ROMFS_PREFIX_LEN;
    for (size_t i = 0; i < romfs_count; ++i) {
        if (strcmp(romfs_entries[i].path, path) == 0) {
            return &romfs_entries[i];
        }
    }
    return NULL;
}

// What the core's loader puts on the heap for the frozen modules (raw-code records, their
// children arrays, the qstr and constant tables, constant objects), which mpy-tool's freezing
// keeps in flash: the growth of the heap's used bytes from opening a module's image to the
// reader's close at the end of the load (before the module runs), summed. Read by
// gcinfo.loader(). A collection during a load would make it smaller, never larger.
static size_t romfs_loader_bytes;
static size_t romfs_loader_modules;
static size_t romfs_used_at_open;
static void (*romfs_mem_close)(void *data);

size_t romfs_loader_heap(size_t *modules) {
    *modules = romfs_loader_modules;
    return romfs_loader_bytes;
}

static size_t romfs_heap_used(void) {
    gc_info_t info;
    gc_info(&info);
    return info.used;
}

static void romfs_close(void *data) {
    romfs_mem_close(data);
    size_t used = romfs_heap_used();
    if (used > romfs_used_at_open) {
        romfs_loader_bytes += used - romfs_used_at_open;
    }
    romfs_loader_modules++;
}

// The core calls this to read a module (MICROPY_VFS_POSIX is set only to leave this to us).
void mp_reader_new_file(mp_reader_t *reader, qstr filename) {
    const char *path = qstr_str(filename);
    const romfs_entry_t *e = romfs_find(path);
    if (e != NULL) {
        romfs_used_at_open = romfs_heap_used();
        mp_reader_new_mem(reader, e->data, e->len, MP_READER_IS_ROM);
        romfs_mem_close = reader->close; // readbyte stays the core's: it memory-maps ROM data
        reader->close = romfs_close;
        return;
    }
    int fd = open(path, O_RDONLY, 0644);
    if (fd < 0) {
        mp_raise_OSError_with_filename(errno, path);
    }
    mp_reader_new_file_from_fd(reader, fd, true);
}

// The qstrs of the frozen modules in a pool of their own outside the heap, registered at start-up
// (romfs_qstr_init, from main.c). mpy-tool's freezing compiles them into the firmware's ROM qstr
// pool, so on the ESP32 they cost no heap; without this pool the core's loader would intern each
// one at import into pools on the heap (about 7 B each, some 20 KB for the firmware), which the
// heap figures of this build would wrongly count (docs/MEMORY.md). Only qstrs the core does not
// already have are added (one string, one qstr number). The last few go into a second small pool
// whose alloc is the core's MICROPY_ALLOC_QSTR_ENTRIES_INIT (10), as mpy-tool writes its frozen pool:
// the core sizes the next (heap) pool at twice the last pool's alloc, so qstrs made at run time
// get the same small heap pools as on the board.
#if TRACKPILOT_ROMFS
#define ROMFS_QSTR_MAX (8192)
#define ROMFS_QSTR_TAIL (10) // py/qstr.c's MICROPY_ALLOC_QSTR_ENTRIES_INIT (local to qstr.c)
static struct {
    qstr_pool_t pool;
    const char *qstrs[ROMFS_QSTR_MAX];
} romfs_qstr_pool;
#if MICROPY_QSTR_BYTES_IN_HASH
static qstr_hash_t romfs_qstr_hashes[ROMFS_QSTR_MAX];
#endif
static qstr_len_t romfs_qstr_lengths[ROMFS_QSTR_MAX];
static struct {
    qstr_pool_t pool;
    const char *qstrs[ROMFS_QSTR_TAIL];
} romfs_qstr_tail;

static size_t romfs_vuint(const unsigned char **p, const unsigned char *end) {
    size_t v = 0;
    while (*p < end) {
        unsigned char b = *(*p)++;
        v = (v << 7) | (b & 0x7f);
        if (!(b & 0x80)) {
            break;
        }
    }
    return v;
}
#endif

size_t romfs_qstr_init(void) {
    #if TRACKPILOT_ROMFS
    qstr_pool_t *pool = &romfs_qstr_pool.pool;
    pool->prev = MP_STATE_VM(last_pool);
    pool->total_prev_len = MP_STATE_VM(last_pool)->total_prev_len + MP_STATE_VM(last_pool)->len;
    pool->is_sorted = 0;
    pool->alloc = ROMFS_QSTR_MAX;
    pool->len = 0;
    #if MICROPY_QSTR_BYTES_IN_HASH
    pool->hashes = romfs_qstr_hashes;
    #endif
    pool->lengths = romfs_qstr_lengths;
    MP_STATE_VM(last_pool) = pool;
    for (size_t i = 0; i < romfs_count; ++i) {
        const unsigned char *p = romfs_entries[i].data;
        const unsigned char *end = p + romfs_entries[i].len;
        if (romfs_entries[i].len < 4 || p[0] != 'M') {
            continue;
        }
        p += 4; // 'M', version, features, small-int bits
        size_t n_qstr = romfs_vuint(&p, end);
        (void)romfs_vuint(&p, end); // n_obj
        for (size_t k = 0; k < n_qstr && p < end; ++k) {
            size_t len = romfs_vuint(&p, end);
            if (len & 1) {
                continue; // one of the core's static qstrs
            }
            len >>= 1;
            const char *str = (const char *)p;
            p += len + 1; // the string and its NUL
            if (p > end || len == 0 || len >= (1u << (8 * MICROPY_QSTR_BYTES_IN_LEN))
                || pool->len >= ROMFS_QSTR_MAX || qstr_find_strn(str, len) != MP_QSTRnull) {
                continue;
            }
            #if MICROPY_QSTR_BYTES_IN_HASH
            pool->hashes[pool->len] = qstr_compute_hash((const byte *)str, len);
            #endif
            pool->lengths[pool->len] = len;
            romfs_qstr_pool.qstrs[pool->len] = str;
            pool->len++;
        }
    }
    // the tail pool: the last entries moved over (same strings, same qstr numbers)
    size_t n_tail = pool->len < ROMFS_QSTR_TAIL ? pool->len : ROMFS_QSTR_TAIL;
    pool->len -= n_tail;
    pool->alloc = pool->len;
    qstr_pool_t *tail = &romfs_qstr_tail.pool;
    tail->prev = pool;
    tail->total_prev_len = pool->total_prev_len + pool->len;
    tail->is_sorted = 0;
    tail->alloc = n_tail; // closed too: ROMFS_QSTR_TAIL whenever there are that many
    tail->len = n_tail;
    #if MICROPY_QSTR_BYTES_IN_HASH
    tail->hashes = romfs_qstr_hashes + pool->len;
    #endif
    tail->lengths = romfs_qstr_lengths + pool->len;
    for (size_t k = 0; k < n_tail; ++k) {
        romfs_qstr_tail.qstrs[k] = romfs_qstr_pool.qstrs[pool->len + k];
    }
    MP_STATE_VM(last_pool) = tail;
    return pool->len + n_tail;
    #else
    return 0;
    #endif
}
