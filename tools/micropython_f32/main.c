// trackpilot f32 port: command line entry point.
//
//   micropython-f32 [-X heapsize=N[k|m]] [-c CODE | SCRIPT.py] [ARGS...]
//
// Runs a script (or CODE) with the MicroPython core built for single-precision floats.
// sys.path = [script dir (or '' for -c)] + MICROPYPATH entries (colon separated) + the lib/
// folder beside the binary.
// An uncaught exception prints a traceback to stderr and exits 1; sys.exit(n) exits n.
#include <errno.h>
#include <stdio.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "py/builtin.h"
#include "py/compile.h"
#include "py/cstack.h"
#include "py/gc.h"
#include "py/mperrno.h"
#include "py/mphal.h"
#include "py/runtime.h"
#include "py/stackctrl.h"
#include "shared/runtime/gchelper.h"

// Same default as the unix port: 2 MB on 64-bit hosts.
#define DEFAULT_HEAP_SIZE (1024 * 1024 * (sizeof(mp_uint_t) / 4))
#define C_STACK_LIMIT (40000 * sizeof(void *))

static void stderr_print_strn(void *env, const char *str, size_t len) {
    (void)env;
    ssize_t r = write(STDERR_FILENO, str, len);
    (void)r;
}

const mp_print_t mp_stderr_print = {NULL, stderr_print_strn};

// romfs.c: modules frozen into the binary (none unless built with --frozen).
size_t romfs_module_count(void);
int romfs_stat(const char *path);
size_t romfs_qstr_init(void);

// Returns the process exit code for an uncaught exception.
static int handle_uncaught_exception(mp_obj_base_t *exc) {
    if (mp_obj_is_subclass_fast(MP_OBJ_FROM_PTR(exc->type), MP_OBJ_FROM_PTR(&mp_type_SystemExit))) {
        mp_obj_t exit_val = mp_obj_exception_get_value(MP_OBJ_FROM_PTR(exc));
        mp_int_t val = 0;
        if (exit_val == mp_const_none) {
            return 0;
        }
        if (mp_obj_get_int_maybe(exit_val, &val)) {
            return val & 255;
        }
        mp_obj_print_helper(&mp_stderr_print, exit_val, PRINT_STR);
        mp_print_str(&mp_stderr_print, "\n");
        return 1;
    }
    mp_obj_print_exception(&mp_stderr_print, MP_OBJ_FROM_PTR(exc));
    return 1;
}

// kind: 0 = file, 1 = string.
static int execute(int kind, const char *src) {
    nlr_buf_t nlr;
    if (nlr_push(&nlr) == 0) {
        mp_lexer_t *lex;
        if (kind == 0) {
            lex = mp_lexer_new_from_file(qstr_from_str(src));
        } else {
            lex = mp_lexer_new_from_str_len(MP_QSTR__lt_stdin_gt_, src, strlen(src), 0);
        }
        qstr source_name = lex->source_name;
        #if MICROPY_MODULE___FILE__
        if (kind == 0) {
            mp_store_global(MP_QSTR___file__, MP_OBJ_NEW_QSTR(source_name));
        }
        #endif
        mp_parse_tree_t pt = mp_parse(lex, MP_PARSE_FILE_INPUT);
        mp_obj_t fun = mp_compile(&pt, source_name, false);
        mp_call_function_0(fun);
        nlr_pop();
        return 0;
    } else {
        return handle_uncaught_exception(nlr.ret_val);
    }
}

static size_t parse_size(const char *s) {
    char *end;
    unsigned long long v = strtoull(s, &end, 0);
    if (*end == 'k' || *end == 'K') {
        v *= 1024;
        ++end;
    } else if (*end == 'm' || *end == 'M') {
        v *= 1024 * 1024;
        ++end;
    }
    if (end == s || *end != '\0' || v < 4096) {
        fprintf(stderr, "micropython-f32: bad heap size '%s'\n", s);
        exit(2);
    }
    return (size_t)v;
}

static int usage(const char *prog) {
    fprintf(stderr,
        "usage: %s [-X heapsize=N[k|m]] [-c CODE | SCRIPT.py] [ARGS...]\n"
        "Single-precision (float32) MicroPython " MICROPY_VERSION_STRING " for host testing.\n"
        "MICROPYPATH: colon-separated module directories added to sys.path.\n", prog);
    return 2;
}

int main(int argc, char **argv) {
    mp_cstack_init_with_sp_here(C_STACK_LIMIT);

    size_t heap_size = DEFAULT_HEAP_SIZE;
    const char *code = NULL;
    const char *script = NULL;
    int a = 1;
    for (; a < argc; ++a) {
        if (strcmp(argv[a], "-X") == 0 && a + 1 < argc) {
            ++a;
            if (strncmp(argv[a], "heapsize=", 9) == 0) {
                heap_size = parse_size(argv[a] + 9);
            } // other -X options are accepted and ignored
        } else if (strncmp(argv[a], "-X", 2) == 0 && argv[a][2] != '\0') {
            if (strncmp(argv[a] + 2, "heapsize=", 9) == 0) {
                heap_size = parse_size(argv[a] + 11);
            }
        } else if (strcmp(argv[a], "-c") == 0 && a + 1 < argc) {
            code = argv[++a];
            ++a;
            break;
        } else if (strcmp(argv[a], "-h") == 0 || strcmp(argv[a], "--help") == 0) {
            usage(argv[0]);
            return 0;
        } else if (argv[a][0] == '-' && argv[a][1] != '\0') {
            fprintf(stderr, "micropython-f32: unsupported option '%s'\n", argv[a]);
            return usage(argv[0]);
        } else {
            script = argv[a++];
            break;
        }
    }
    if (code == NULL && script == NULL) {
        return usage(argv[0]);
    }

    char *heap = malloc(heap_size);
    if (heap == NULL) {
        fprintf(stderr, "micropython-f32: can't allocate %zu byte heap\n", heap_size);
        return 1;
    }
    gc_init(heap, heap + heap_size);
    mp_init();
    romfs_qstr_init(); // the frozen modules' qstrs, outside the heap as in a real freeze

    // sys.path: [".frozen" in the frozen-firmware build,] script directory (or '') then
    // MICROPYPATH entries. Frozen modules come first, as on the ESP32, so that the firmware's
    // source folders on MICROPYPATH do not shadow them.
    mp_obj_list_init(MP_OBJ_TO_PTR(mp_sys_path), 0);
    if (romfs_module_count() > 0) {
        mp_obj_list_append(mp_sys_path, mp_obj_new_str_from_cstr(".frozen"));
    }
    if (script != NULL) {
        const char *slash = strrchr(script, '/');
        mp_obj_list_append(mp_sys_path, slash ? mp_obj_new_str_via_qstr(script, slash - script) : MP_OBJ_NEW_QSTR(MP_QSTR_));
    } else {
        mp_obj_list_append(mp_sys_path, MP_OBJ_NEW_QSTR(MP_QSTR_));
    }
    const char *mpath = getenv("MICROPYPATH");
    while (mpath != NULL && *mpath != '\0') {
        const char *colon = strchr(mpath, ':');
        size_t n = colon ? (size_t)(colon - mpath) : strlen(mpath);
        mp_obj_list_append(mp_sys_path, mp_obj_new_str_via_qstr(mpath, n));
        mpath = colon ? colon + 1 : NULL;
    }

    // Then the lib/ folder beside the binary (asyncio from PyPI, put there by the build script).
    static char exe_path[4096];
    ssize_t exe_len = readlink("/proc/self/exe", exe_path, sizeof(exe_path) - 5);
    if (exe_len > 0) {
        exe_path[exe_len] = '\0';
        char *slash = strrchr(exe_path, '/');
        if (slash != NULL) {
            strcpy(slash + 1, "lib");
            mp_obj_list_append(mp_sys_path, mp_obj_new_str_from_cstr(exe_path));
        }
    }

    // sys.argv: the script (or '-c') and the remaining arguments.
    mp_obj_list_init(MP_OBJ_TO_PTR(mp_sys_argv), 0);
    mp_obj_list_append(mp_sys_argv, mp_obj_new_str_from_cstr(script ? script : "-c"));
    for (; a < argc; ++a) {
        mp_obj_list_append(mp_sys_argv, mp_obj_new_str_from_cstr(argv[a]));
    }

    int ret;
    if (script != NULL) {
        struct stat st;
        if (stat(script, &st) != 0 || !S_ISREG(st.st_mode)) {
            fprintf(stderr, "%s: can't open file '%s': [Errno %d] %s\n", argv[0], script,
                errno ? errno : ENOENT, strerror(errno ? errno : ENOENT));
            ret = 2;
        } else {
            ret = execute(0, script);
        }
    } else {
        ret = execute(1, code);
    }

    #if MICROPY_ENABLE_FINALISER
    gc_sweep_all(); // runs __del__ (closes files still open)
    #endif
    mp_deinit();
    free(heap);
    return ret;
}

// Collections and their CPU time (gcinfo.collections()): every collection, the app's own and
// those gc.threshold() triggers. CPU time of this thread, so other processes on a busy host do
// not count; on the unix port, not an ESP32 figure.
size_t gcinfo_n_collections;
uint64_t gcinfo_collect_cpu_ns;
uint64_t gcinfo_collect_cpu_max_ns;
uint64_t gcinfo_blocks_before;  // blocks allocated up to the last collection (gc_alloc_amount is reset there)

void gc_collect(void) {
    struct timespec t0, t1;
    gcinfo_blocks_before += MP_STATE_MEM(gc_alloc_amount);
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t0);
    gc_collect_start();
    gc_helper_collect_regs_and_stack();
    gc_collect_end();
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t1);
    uint64_t ns = (uint64_t)(t1.tv_sec - t0.tv_sec) * 1000000000u + (uint64_t)t1.tv_nsec - (uint64_t)t0.tv_nsec;
    gcinfo_n_collections++;
    gcinfo_collect_cpu_ns += ns;
    if (ns > gcinfo_collect_cpu_max_ns) {
        gcinfo_collect_cpu_max_ns = ns;
    }
}

mp_import_stat_t mp_import_stat(const char *path) {
    int rom = romfs_stat(path);
    if (rom != 0) {
        return rom == 1 ? MP_IMPORT_STAT_FILE : MP_IMPORT_STAT_DIR;
    }
    struct stat st;
    if (stat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode)) {
            return MP_IMPORT_STAT_DIR;
        } else if (S_ISREG(st.st_mode)) {
            return MP_IMPORT_STAT_FILE;
        }
    }
    return MP_IMPORT_STAT_NO_EXIST;
}

void nlr_jump_fail(void *val) {
    fprintf(stderr, "FATAL: uncaught NLR %p\n", val);
    exit(1);
}

void MP_NORETURN __fatal_error(const char *msg) {
    fprintf(stderr, "FATAL: %s\n", msg);
    exit(1);
}

#ifndef NDEBUG
void MP_WEAK __assert_func(const char *file, int line, const char *func, const char *expr) {
    fprintf(stderr, "Assertion '%s' failed, at file %s:%d\n", expr, file, line);
    __fatal_error("Assertion failed");
}
#endif
