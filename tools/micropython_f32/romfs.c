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

// The core calls this to read a module (MICROPY_VFS_POSIX is set only to leave this to us).
void mp_reader_new_file(mp_reader_t *reader, qstr filename) {
    const char *path = qstr_str(filename);
    const romfs_entry_t *e = romfs_find(path);
    if (e != NULL) {
        mp_reader_new_mem(reader, e->data, e->len, MP_READER_IS_ROM);
        return;
    }
    int fd = open(path, O_RDONLY, 0644);
    if (fd < 0) {
        mp_raise_OSError_with_filename(errno, path);
    }
    mp_reader_new_file_from_fd(reader, fd, true);
}
