// trackpilot: configuration of the single-precision (float32) MicroPython host interpreter.
// A small embedding "port" of the MicroPython 1.28 core (py/) that runs scripts on Linux with
// the same float width as the ESP32 build.  See tools/README.md.
#include <stdint.h>
#include <alloca.h>

#define MICROPY_CONFIG_ROM_LEVEL            (MICROPY_CONFIG_ROM_LEVEL_EXTRA_FEATURES)

// The point of this build: single-precision floats, as on the ESP32.
#define MICROPY_FLOAT_IMPL                  (MICROPY_FLOAT_IMPL_FLOAT)
#define MICROPY_LONGINT_IMPL                (MICROPY_LONGINT_IMPL_MPZ)

// Memory: GC heap is malloc'ed in main.c (2 MB like the unix port, or -X heapsize=N).
#define MICROPY_ENABLE_GC                   (1)
#define MICROPY_ENABLE_FINALISER            (1)
#define MICROPY_STACK_CHECK                 (1)
#define MICROPY_GCREGS_SETJMP               (0)
#define MICROPY_ALLOC_PATH_MAX              (4096)
#define MICROPY_ENABLE_EMERGENCY_EXCEPTION_BUF (1)
#define MICROPY_EMERGENCY_EXCEPTION_BUF_SIZE (256)

// No native code emitters (keeps the port architecture independent).
#define MICROPY_EMIT_X64                    (0)
#define MICROPY_EMIT_X86                    (0)
#define MICROPY_EMIT_THUMB                  (0)
#define MICROPY_EMIT_INLINE_THUMB           (0)
#define MICROPY_EMIT_ARM                    (0)
#define MICROPY_EMIT_XTENSA                 (0)
#define MICROPY_EMIT_INLINE_XTENSA          (0)
#define MICROPY_EMIT_XTENSAWIN              (0)
#define MICROPY_EMIT_RV32                   (0)
#define MICROPY_EMIT_INLINE_RV32            (0)

// Compiler / import of .py files straight from the POSIX file system.
#define MICROPY_ENABLE_COMPILER             (1)
#define MICROPY_ENABLE_EXTERNAL_IMPORT      (1)
#define MICROPY_READER_POSIX                (1)
#define MICROPY_READER_VFS                  (0)
#define MICROPY_VFS                         (0)
#define MICROPY_MODULE_OVERRIDE_MAIN_IMPORT (1)
#define MICROPY_PERSISTENT_CODE_LOAD        (1)
// Module files are read by romfs.c's mp_reader_new_file (frozen .mpy images, then files): the
// core leaves that function to the port when MICROPY_VFS_POSIX is set (no VFS is built).
#define MICROPY_VFS_POSIX                   (1)
#ifndef TRACKPILOT_ROMFS
#define TRACKPILOT_ROMFS                    (0)
#endif
// Frozen-firmware build: import .mpy images in place (bytecode, strings and qstrs not copied).
#define MICROPY_VFS_ROM                     (TRACKPILOT_ROMFS)
#define MICROPY_VFS_ROM_IOCTL               (0)
#define MICROPY_HELPER_REPL                 (1)
#define MICROPY_KBD_EXCEPTION               (0)
#define MICROPY_REPL_EVENT_DRIVEN           (0)
#define MICROPY_USE_READLINE                (0)

// Error reporting like the unix port.
#define MICROPY_ERROR_REPORTING             (MICROPY_ERROR_REPORTING_DETAILED)
#define MICROPY_ENABLE_SOURCE_LINE          (1)
#define MICROPY_ERROR_PRINTER               (&mp_stderr_print)
#define MICROPY_DEBUG_PRINTER               (&mp_stderr_print)
#define MICROPY_WARNINGS                    (1)

// Language features (most come with EXTRA_FEATURES; spelled out the ones tests rely on).
#define MICROPY_PY_FSTRINGS                 (1)
#define MICROPY_PY_ASYNC_AWAIT              (1)
#define MICROPY_PY_ASSIGN_EXPR              (1)
#define MICROPY_PY_BUILTINS_FLOAT           (1)
#define MICROPY_PY_BUILTINS_COMPLEX         (1)
#define MICROPY_PY_BUILTINS_HELP            (1)
#define MICROPY_PY_BUILTINS_HELP_MODULES    (1)
#define MICROPY_PY_BUILTINS_INPUT           (0)
#define MICROPY_PY_BUILTINS_STR_UNICODE     (1)
#define MICROPY_PY_BUILTINS_ROUND_INT       (1)

// Built-in modules from py/ (plus time, os and open() from this directory).
#define MICROPY_PY_MATH                     (1)
#define MICROPY_PY_MATH_SPECIAL_FUNCTIONS   (1)
#define MICROPY_PY_MATH_ISCLOSE             (1)
#define MICROPY_PY_MATH_FACTORIAL           (1)
#define MICROPY_PY_CMATH                    (1)
#define MICROPY_PY_STRUCT                   (1)
#define MICROPY_PY_ARRAY                    (1)
#define MICROPY_PY_COLLECTIONS              (1)
#define MICROPY_PY_COLLECTIONS_DEQUE        (1)
#define MICROPY_PY_COLLECTIONS_DEQUE_ITER   (1)
#define MICROPY_PY_COLLECTIONS_DEQUE_SUBSCR (1)
#define MICROPY_PY_COLLECTIONS_ORDEREDDICT  (1)
#define MICROPY_PY_GC                       (1)
#define MICROPY_PY_IO                       (1)
#define MICROPY_PY_IO_IOBASE                (1)
#define MICROPY_PY_IO_BYTESIO               (1)
#define MICROPY_PY_ERRNO                    (1)
#define MICROPY_PY_MICROPYTHON              (1)
#define MICROPY_PY_MICROPYTHON_MEM_INFO     (1)
#define MICROPY_PY_MICROPYTHON_STACK_USE    (1)
#define MICROPY_PY_MICROPYTHON_HEAP_LOCKED  (1)
#define MICROPY_PY_SYS                      (1)
#define MICROPY_PY_SYS_ARGV                 (1)
#define MICROPY_PY_SYS_PATH                 (1)
#define MICROPY_PY_SYS_EXIT                 (1)
#define MICROPY_PY_SYS_MODULES              (1)
#define MICROPY_PY_SYS_MAXSIZE              (1)
#define MICROPY_PY_SYS_STDFILES             (1)
#define MICROPY_PY_SYS_STDIO_BUFFER         (1)
#define MICROPY_PY_SYS_PLATFORM             "linux"
#define MICROPY_PY_SYS_EXC_INFO             (1)

// Modules that live in extmod/ (not shipped in the sdist): json, binascii, random, heapq and
// hashlib (sha256 only) are our own small versions in this directory (mod*.c); the rest are off.
#define MICROPY_PY_TIME                     (0)
#define MICROPY_PY_OS                       (0)
#define MICROPY_PY_JSON                     (1)
#define MICROPY_PY_JSON_SEPARATORS          (1)
#define MICROPY_PY_BINASCII                 (1)
#define MICROPY_PY_BINASCII_CRC32           (1)
#define MICROPY_PY_RANDOM                   (1)
#define MICROPY_PY_RANDOM_EXTRA_FUNCS       (1)
#define MICROPY_PY_HEAPQ                    (1)
#define MICROPY_PY_HASHLIB                  (1)
#define MICROPY_PY_HASHLIB_SHA256           (1)
#define MICROPY_PY_HASHLIB_SHA1             (0)
#define MICROPY_PY_HASHLIB_MD5              (0)
#define MICROPY_PY_RE                       (0)
#define MICROPY_PY_SELECT                   (0) // our own select.poll: modselect.c
#define MICROPY_PY_ASYNCIO                  (0)
#define MICROPY_PY_DEFLATE                  (0)
#define MICROPY_PY_FRAMEBUF                 (1) // modframebuf.c, if the font header was generated
#define MICROPY_PY_UCTYPES                  (0)
#define MICROPY_PY_PLATFORM                 (0)
#define MICROPY_PY_MACHINE                  (0)
#define MICROPY_PY_THREAD                   (0)
#define MICROPY_PY_SOCKET                   (0)
#define MICROPY_PY_CRYPTOLIB                (0)
#define MICROPY_PY_VFS                      (0)

// Types.
typedef intptr_t mp_int_t;
typedef uintptr_t mp_uint_t;
typedef long mp_off_t;

#define MICROPY_HW_BOARD_NAME               "linux"
#define MICROPY_HW_MCU_NAME                 "float32 host build"
#define MICROPY_BANNER_MACHINE              "trackpilot f32 host build"
#define MP_STATE_PORT MP_STATE_VM

// Printer for errors/warnings/tracebacks, defined in main.c (writes to fd 2).
extern const struct _mp_print_t mp_stderr_print;
