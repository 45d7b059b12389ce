// trackpilot f32 port: POSIX file objects for open(), sys.stdin/stdout/stderr (+ .buffer),
// and the HAL console functions.
#include <poll.h>
#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include "py/builtin.h"
#include "py/mperrno.h"
#include "py/mphal.h"
#include "py/runtime.h"
#include "py/stream.h"

typedef struct _f32_file_obj_t {
    mp_obj_base_t base;
    int fd;
} f32_file_obj_t;

extern const mp_obj_type_t f32_type_fileio;
extern const mp_obj_type_t f32_type_textio;

static void check_open(f32_file_obj_t *o) {
    if (o->fd < 0) {
        mp_raise_ValueError(MP_ERROR_TEXT("I/O operation on closed file"));
    }
}

static void file_print(const mp_print_t *print, mp_obj_t self_in, mp_print_kind_t kind) {
    (void)kind;
    f32_file_obj_t *self = MP_OBJ_TO_PTR(self_in);
    mp_printf(print, "<io.%s %d>", mp_obj_get_type_str(self_in), self->fd);
}

static mp_uint_t file_read(mp_obj_t o_in, void *buf, mp_uint_t size, int *errcode) {
    f32_file_obj_t *o = MP_OBJ_TO_PTR(o_in);
    check_open(o);
    for (;;) {
        ssize_t r = read(o->fd, buf, size);
        if (r >= 0) {
            return r;
        }
        if (errno != EINTR) {
            *errcode = errno;
            return MP_STREAM_ERROR;
        }
        mp_handle_pending(true);
    }
}

static mp_uint_t file_write(mp_obj_t o_in, const void *buf, mp_uint_t size, int *errcode) {
    f32_file_obj_t *o = MP_OBJ_TO_PTR(o_in);
    check_open(o);
    const char *p = buf;
    mp_uint_t left = size;
    while (left > 0) {
        ssize_t r = write(o->fd, p, left);
        if (r < 0) {
            if (errno == EINTR) {
                mp_handle_pending(true);
                continue;
            }
            *errcode = errno;
            return MP_STREAM_ERROR;
        }
        p += r;
        left -= r;
    }
    return size;
}

// The readiness of a file descriptor for MP_STREAM_POLL, without waiting (files and sockets).
mp_uint_t f32_fd_poll(int fd, uintptr_t arg, int *errcode) {
    struct pollfd pfd = {fd, 0, 0};
    if (arg & MP_STREAM_POLL_RD) {
        pfd.events |= POLLIN;
    }
    if (arg & MP_STREAM_POLL_WR) {
        pfd.events |= POLLOUT;
    }
    if (poll(&pfd, 1, 0) < 0) {
        *errcode = errno;
        return MP_STREAM_ERROR;
    }
    mp_uint_t ready = 0;
    if (pfd.revents & POLLIN) {
        ready |= MP_STREAM_POLL_RD;
    }
    if (pfd.revents & POLLOUT) {
        ready |= MP_STREAM_POLL_WR;
    }
    if (pfd.revents & POLLERR) {
        ready |= MP_STREAM_POLL_ERR;
    }
    if (pfd.revents & POLLHUP) {
        ready |= MP_STREAM_POLL_HUP;
    }
    return ready;
}

static mp_uint_t file_ioctl(mp_obj_t o_in, mp_uint_t request, uintptr_t arg, int *errcode) {
    f32_file_obj_t *o = MP_OBJ_TO_PTR(o_in);
    if (request != MP_STREAM_CLOSE) {
        check_open(o);
    }
    switch (request) {
        case MP_STREAM_FLUSH:
            return 0;
        case MP_STREAM_SEEK: {
            struct mp_stream_seek_t *s = (struct mp_stream_seek_t *)arg;
            off_t off = lseek(o->fd, s->offset, s->whence);
            if (off == (off_t)-1) {
                *errcode = errno;
                return MP_STREAM_ERROR;
            }
            s->offset = off;
            return 0;
        }
        case MP_STREAM_CLOSE:
            if (o->fd > 2) { // never close the process's stdio
                close(o->fd);
            }
            if (o->fd >= 0 && o->fd > 2) {
                o->fd = -1;
            }
            return 0;
        case MP_STREAM_GET_FILENO:
            return o->fd;
        case MP_STREAM_POLL: // select.poll: ask the descriptor, without waiting
            return f32_fd_poll(o->fd, arg, errcode);
        default:
            *errcode = MP_EINVAL;
            return MP_STREAM_ERROR;
    }
}

static mp_obj_t file_fileno(mp_obj_t self_in) {
    f32_file_obj_t *self = MP_OBJ_TO_PTR(self_in);
    check_open(self);
    return MP_OBJ_NEW_SMALL_INT(self->fd);
}
static MP_DEFINE_CONST_FUN_OBJ_1(file_fileno_obj, file_fileno);

static const mp_rom_map_elem_t file_locals_dict_table[] = {
    { MP_ROM_QSTR(MP_QSTR_fileno), MP_ROM_PTR(&file_fileno_obj) },
    { MP_ROM_QSTR(MP_QSTR_read), MP_ROM_PTR(&mp_stream_read_obj) },
    { MP_ROM_QSTR(MP_QSTR_readinto), MP_ROM_PTR(&mp_stream_readinto_obj) },
    { MP_ROM_QSTR(MP_QSTR_readline), MP_ROM_PTR(&mp_stream_unbuffered_readline_obj) },
    { MP_ROM_QSTR(MP_QSTR_readlines), MP_ROM_PTR(&mp_stream_unbuffered_readlines_obj) },
    { MP_ROM_QSTR(MP_QSTR_write), MP_ROM_PTR(&mp_stream_write_obj) },
    { MP_ROM_QSTR(MP_QSTR_seek), MP_ROM_PTR(&mp_stream_seek_obj) },
    { MP_ROM_QSTR(MP_QSTR_tell), MP_ROM_PTR(&mp_stream_tell_obj) },
    { MP_ROM_QSTR(MP_QSTR_flush), MP_ROM_PTR(&mp_stream_flush_obj) },
    { MP_ROM_QSTR(MP_QSTR_close), MP_ROM_PTR(&mp_stream_close_obj) },
    { MP_ROM_QSTR(MP_QSTR___enter__), MP_ROM_PTR(&mp_identity_obj) },
    { MP_ROM_QSTR(MP_QSTR___exit__), MP_ROM_PTR(&mp_stream___exit___obj) },
    { MP_ROM_QSTR(MP_QSTR___del__), MP_ROM_PTR(&mp_stream_close_obj) },
};
static MP_DEFINE_CONST_DICT(file_locals_dict, file_locals_dict_table);

static mp_obj_t stdio_buffer(mp_obj_t self_in);

// Text files answer `.buffer` for the three std streams (sys.stdout.buffer.write(b'..')),
// everything else is looked up in the locals dict.
static void textio_attr(mp_obj_t self_in, qstr attr, mp_obj_t *dest) {
    if (dest[0] == MP_OBJ_NULL && attr == MP_QSTR_buffer) {
        mp_obj_t b = stdio_buffer(self_in);
        if (b != MP_OBJ_NULL) {
            dest[0] = b;
            return;
        }
    }
    dest[1] = MP_OBJ_SENTINEL;
}

static const mp_stream_p_t fileio_stream_p = {
    .read = file_read,
    .write = file_write,
    .ioctl = file_ioctl,
};

static const mp_stream_p_t textio_stream_p = {
    .read = file_read,
    .write = file_write,
    .ioctl = file_ioctl,
    .is_text = true,
};

MP_DEFINE_CONST_OBJ_TYPE(
    f32_type_fileio,
    MP_QSTR_FileIO,
    MP_TYPE_FLAG_ITER_IS_STREAM,
    print, file_print,
    protocol, &fileio_stream_p,
    locals_dict, &file_locals_dict
    );

MP_DEFINE_CONST_OBJ_TYPE(
    f32_type_textio,
    MP_QSTR_TextIOWrapper,
    MP_TYPE_FLAG_ITER_IS_STREAM,
    print, file_print,
    attr, textio_attr,
    protocol, &textio_stream_p,
    locals_dict, &file_locals_dict
    );

// open(file, mode='r', buffering=-1, encoding=None): file is a path or an int fd.
static mp_obj_t f32_open(size_t n_args, const mp_obj_t *pos_args, mp_map_t *kw_args) {
    enum { ARG_file, ARG_mode, ARG_buffering, ARG_encoding };
    static const mp_arg_t allowed_args[] = {
        { MP_QSTR_file, MP_ARG_OBJ | MP_ARG_REQUIRED, {.u_rom_obj = MP_ROM_NONE} },
        { MP_QSTR_mode, MP_ARG_OBJ, {.u_rom_obj = MP_ROM_QSTR(MP_QSTR_r)} },
        { MP_QSTR_buffering, MP_ARG_INT, {.u_int = -1} },
        { MP_QSTR_encoding, MP_ARG_OBJ, {.u_rom_obj = MP_ROM_NONE} },
    };
    mp_arg_val_t args[MP_ARRAY_SIZE(allowed_args)];
    mp_arg_parse_all(n_args, pos_args, kw_args, MP_ARRAY_SIZE(allowed_args), allowed_args, args);

    const char *mode = mp_obj_str_get_str(args[ARG_mode].u_obj);
    int flags = 0;
    const mp_obj_type_t *type = &f32_type_textio;
    for (const char *m = mode; *m; ++m) {
        switch (*m) {
            case 'r':
                flags = (flags & ~O_ACCMODE) | O_RDONLY;
                break;
            case 'w':
                flags = (flags & ~O_ACCMODE) | O_WRONLY | O_CREAT | O_TRUNC;
                break;
            case 'a':
                flags = (flags & ~O_ACCMODE) | O_WRONLY | O_CREAT | O_APPEND;
                break;
            case 'x':
                flags = (flags & ~O_ACCMODE) | O_WRONLY | O_CREAT | O_EXCL;
                break;
            case '+':
                flags = (flags & ~O_ACCMODE) | O_RDWR;
                break;
            case 'b':
                type = &f32_type_fileio;
                break;
            case 't':
                type = &f32_type_textio;
                break;
            default:
                mp_raise_msg_varg(&mp_type_ValueError, MP_ERROR_TEXT("invalid mode: '%s'"), mode);
        }
    }

    f32_file_obj_t *o = mp_obj_malloc_with_finaliser(f32_file_obj_t, type);
    mp_obj_t fid = args[ARG_file].u_obj;
    if (mp_obj_is_small_int(fid)) {
        o->fd = MP_OBJ_SMALL_INT_VALUE(fid);
        return MP_OBJ_FROM_PTR(o);
    }
    const char *fname = mp_obj_str_get_str(fid);
    int fd;
    for (;;) {
        fd = open(fname, flags | O_CLOEXEC, 0644);
        if (fd >= 0 || errno != EINTR) {
            break;
        }
        mp_handle_pending(true);
    }
    if (fd < 0) {
        o->fd = -1;
        mp_raise_OSError(errno);
    }
    o->fd = fd;
    return MP_OBJ_FROM_PTR(o);
}
MP_DEFINE_CONST_FUN_OBJ_KW(mp_builtin_open_obj, 1, f32_open);

// sys.stdin / sys.stdout / sys.stderr are text files on fds 0/1/2; .buffer gives binary ones.
const f32_file_obj_t mp_sys_stdin_obj = {{&f32_type_textio}, STDIN_FILENO};
const f32_file_obj_t mp_sys_stdout_obj = {{&f32_type_textio}, STDOUT_FILENO};
const f32_file_obj_t mp_sys_stderr_obj = {{&f32_type_textio}, STDERR_FILENO};
static const f32_file_obj_t stdin_buffer_obj = {{&f32_type_fileio}, STDIN_FILENO};
static const f32_file_obj_t stdout_buffer_obj = {{&f32_type_fileio}, STDOUT_FILENO};
static const f32_file_obj_t stderr_buffer_obj = {{&f32_type_fileio}, STDERR_FILENO};

static mp_obj_t stdio_buffer(mp_obj_t self_in) {
    const void *p = MP_OBJ_TO_PTR(self_in);
    if (p == &mp_sys_stdin_obj) {
        return MP_OBJ_FROM_PTR(&stdin_buffer_obj);
    } else if (p == &mp_sys_stdout_obj) {
        return MP_OBJ_FROM_PTR(&stdout_buffer_obj);
    } else if (p == &mp_sys_stderr_obj) {
        return MP_OBJ_FROM_PTR(&stderr_buffer_obj);
    }
    return MP_OBJ_NULL;
}

// HAL console functions used by print() and the core.
int mp_hal_stdin_rx_chr(void) {
    unsigned char c;
    ssize_t r;
    do {
        r = read(STDIN_FILENO, &c, 1);
    } while (r < 0 && errno == EINTR);
    return r == 1 ? c : 4; // 4 = Ctrl-D on EOF
}

mp_uint_t mp_hal_stdout_tx_strn(const char *str, size_t len) {
    size_t left = len;
    while (left > 0) {
        ssize_t r = write(STDOUT_FILENO, str, left);
        if (r < 0) {
            if (errno == EINTR) {
                continue;
            }
            break;
        }
        str += r;
        left -= r;
    }
    return len - left;
}

void mp_hal_stdout_tx_strn_cooked(const char *str, size_t len) {
    mp_hal_stdout_tx_strn(str, len);
}

void mp_hal_stdout_tx_str(const char *str) {
    mp_hal_stdout_tx_strn(str, strlen(str));
}
