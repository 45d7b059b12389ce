// trackpilot f32 port: a small `socket` module over POSIX sockets, what the firmware, the HMI and
// asyncio's open_connection use (the unix port's modsocket needs extmod/, which the sdist lacks).
// As in the unix port, addresses are raw `struct sockaddr` bytes (from getaddrinfo/recvfrom).
// Sockets are streams: read/readinto/write, and select.poll asks poll(2) about them.
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>
#include <netinet/in.h>

#include "py/mperrno.h"
#include "py/mphal.h"
#include "py/objstr.h"
#include "py/runtime.h"
#include "py/stream.h"

typedef struct _socket_obj_t {
    mp_obj_base_t base;
    int fd;
    bool blocking;
} socket_obj_t;

static const mp_obj_type_t socket_type;

static void raise_errno(int err) {
    mp_raise_OSError(err);
}

static socket_obj_t *get_open(mp_obj_t self_in) {
    socket_obj_t *self = MP_OBJ_TO_PTR(self_in);
    if (self->fd < 0) {
        raise_errno(MP_EBADF);
    }
    return self;
}

static mp_obj_t socket_make_new(const mp_obj_type_t *type, size_t n_args, size_t n_kw, const mp_obj_t *args) {
    mp_arg_check_num(n_args, n_kw, 0, 3, false);
    int family = n_args > 0 ? mp_obj_get_int(args[0]) : AF_INET;
    int kind = n_args > 1 ? mp_obj_get_int(args[1]) : SOCK_STREAM;
    int proto = n_args > 2 ? mp_obj_get_int(args[2]) : 0;
    int fd = socket(family, kind, proto);
    if (fd < 0) {
        raise_errno(errno);
    }
    socket_obj_t *self = mp_obj_malloc_with_finaliser(socket_obj_t, type);
    self->fd = fd;
    self->blocking = true;
    return MP_OBJ_FROM_PTR(self);
}

static mp_uint_t socket_read(mp_obj_t self_in, void *buf, mp_uint_t size, int *errcode) {
    socket_obj_t *self = MP_OBJ_TO_PTR(self_in);
    ssize_t r;
    while ((r = read(self->fd, buf, size)) < 0 && errno == EINTR) {
        mp_handle_pending(true);
    }
    if (r < 0) {
        *errcode = errno;
        return MP_STREAM_ERROR;
    }
    return r;
}

static mp_uint_t socket_write(mp_obj_t self_in, const void *buf, mp_uint_t size, int *errcode) {
    socket_obj_t *self = MP_OBJ_TO_PTR(self_in);
    ssize_t r;
    while ((r = send(self->fd, buf, size, MSG_NOSIGNAL)) < 0 && errno == EINTR) {
        mp_handle_pending(true);
    }
    if (r < 0) {
        *errcode = errno;
        return MP_STREAM_ERROR;
    }
    return r;
}

static mp_uint_t socket_ioctl(mp_obj_t self_in, mp_uint_t request, uintptr_t arg, int *errcode) {
    socket_obj_t *self = MP_OBJ_TO_PTR(self_in);
    switch (request) {
        case MP_STREAM_CLOSE:
            if (self->fd >= 0) {
                close(self->fd);
                self->fd = -1;
            }
            return 0;
        case MP_STREAM_GET_FILENO:
            return self->fd;
        case MP_STREAM_POLL: {
            if (self->fd < 0) {
                return MP_STREAM_POLL_NVAL;
            }
            return f32_fd_poll(self->fd, arg, errcode);
        }
        default:
            *errcode = MP_EINVAL;
            return MP_STREAM_ERROR;
    }
}

static mp_obj_t socket_connect(mp_obj_t self_in, mp_obj_t addr_in) {
    socket_obj_t *self = get_open(self_in);
    mp_buffer_info_t addr;
    mp_get_buffer_raise(addr_in, &addr, MP_BUFFER_READ);
    if (connect(self->fd, (const struct sockaddr *)addr.buf, addr.len) < 0) {
        raise_errno(errno);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_connect_obj, socket_connect);

static mp_obj_t socket_bind(mp_obj_t self_in, mp_obj_t addr_in) {
    socket_obj_t *self = get_open(self_in);
    mp_buffer_info_t addr;
    mp_get_buffer_raise(addr_in, &addr, MP_BUFFER_READ);
    if (bind(self->fd, (const struct sockaddr *)addr.buf, addr.len) < 0) {
        raise_errno(errno);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_bind_obj, socket_bind);

static mp_obj_t socket_listen(size_t n_args, const mp_obj_t *args) {
    socket_obj_t *self = get_open(args[0]);
    if (listen(self->fd, n_args > 1 ? mp_obj_get_int(args[1]) : SOMAXCONN) < 0) {
        raise_errno(errno);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(socket_listen_obj, 1, 2, socket_listen);

static mp_obj_t socket_send(mp_obj_t self_in, mp_obj_t data_in) {
    socket_obj_t *self = get_open(self_in);
    mp_buffer_info_t data;
    mp_get_buffer_raise(data_in, &data, MP_BUFFER_READ);
    int err;
    mp_uint_t r = socket_write(self_in, data.buf, data.len, &err);
    (void)self;
    if (r == MP_STREAM_ERROR) {
        raise_errno(err);
    }
    return MP_OBJ_NEW_SMALL_INT(r);
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_send_obj, socket_send);

static mp_obj_t socket_recv(mp_obj_t self_in, mp_obj_t len_in) {
    socket_obj_t *self = get_open(self_in);
    vstr_t vstr;
    vstr_init_len(&vstr, mp_obj_get_int(len_in));
    ssize_t r = recv(self->fd, vstr.buf, vstr.len, 0);
    if (r < 0) {
        vstr_clear(&vstr);
        raise_errno(errno);
    }
    vstr.len = r;
    return mp_obj_new_bytes_from_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_recv_obj, socket_recv);

static mp_obj_t socket_sendto(mp_obj_t self_in, mp_obj_t data_in, mp_obj_t addr_in) {
    socket_obj_t *self = get_open(self_in);
    mp_buffer_info_t data, addr;
    mp_get_buffer_raise(data_in, &data, MP_BUFFER_READ);
    mp_get_buffer_raise(addr_in, &addr, MP_BUFFER_READ);
    ssize_t r = sendto(self->fd, data.buf, data.len, MSG_NOSIGNAL, (const struct sockaddr *)addr.buf, addr.len);
    if (r < 0) {
        raise_errno(errno);
    }
    return MP_OBJ_NEW_SMALL_INT(r);
}
static MP_DEFINE_CONST_FUN_OBJ_3(socket_sendto_obj, socket_sendto);

static mp_obj_t socket_recvfrom(mp_obj_t self_in, mp_obj_t len_in) {
    socket_obj_t *self = get_open(self_in);
    vstr_t vstr;
    vstr_init_len(&vstr, mp_obj_get_int(len_in));
    struct sockaddr_storage from;
    socklen_t from_len = sizeof(from);
    ssize_t r = recvfrom(self->fd, vstr.buf, vstr.len, 0, (struct sockaddr *)&from, &from_len);
    if (r < 0) {
        vstr_clear(&vstr);
        raise_errno(errno);
    }
    vstr.len = r;
    mp_obj_t items[2] = {mp_obj_new_bytes_from_vstr(&vstr), mp_obj_new_bytes((const byte *)&from, from_len)};
    return mp_obj_new_tuple(2, items);
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_recvfrom_obj, socket_recvfrom);

static mp_obj_t socket_setsockopt(size_t n_args, const mp_obj_t *args) {
    socket_obj_t *self = get_open(args[0]);
    int level = mp_obj_get_int(args[1]);
    int opt = mp_obj_get_int(args[2]);
    int r;
    if (mp_obj_is_int(args[3])) {
        int v = mp_obj_get_int(args[3]);
        r = setsockopt(self->fd, level, opt, &v, sizeof(v));
    } else {
        mp_buffer_info_t buf;
        mp_get_buffer_raise(args[3], &buf, MP_BUFFER_READ);
        r = setsockopt(self->fd, level, opt, buf.buf, buf.len);
    }
    if (r < 0) {
        raise_errno(errno);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(socket_setsockopt_obj, 4, 4, socket_setsockopt);

static mp_obj_t socket_setblocking(mp_obj_t self_in, mp_obj_t flag_in) {
    socket_obj_t *self = get_open(self_in);
    int flags = fcntl(self->fd, F_GETFL, 0);
    self->blocking = mp_obj_is_true(flag_in);
    flags = self->blocking ? (flags & ~O_NONBLOCK) : (flags | O_NONBLOCK);
    if (fcntl(self->fd, F_SETFL, flags) < 0) {
        raise_errno(errno);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_setblocking_obj, socket_setblocking);

// settimeout(None) blocks, settimeout(0) does not; other timeouts are not supported here.
static mp_obj_t socket_settimeout(mp_obj_t self_in, mp_obj_t timeout_in) {
    if (timeout_in == mp_const_none) {
        return socket_setblocking(self_in, mp_const_true);
    }
    if (mp_obj_get_float(timeout_in) == 0) {
        return socket_setblocking(self_in, mp_const_false);
    }
    mp_raise_NotImplementedError(MP_ERROR_TEXT("settimeout: only None or 0"));
}
static MP_DEFINE_CONST_FUN_OBJ_2(socket_settimeout_obj, socket_settimeout);

static mp_obj_t socket_getsockname(mp_obj_t self_in) {
    socket_obj_t *self = get_open(self_in);
    struct sockaddr_storage addr;
    socklen_t len = sizeof(addr);
    if (getsockname(self->fd, (struct sockaddr *)&addr, &len) < 0) {
        raise_errno(errno);
    }
    return mp_obj_new_bytes((const byte *)&addr, len);
}
static MP_DEFINE_CONST_FUN_OBJ_1(socket_getsockname_obj, socket_getsockname);

static mp_obj_t socket_fileno(mp_obj_t self_in) {
    return MP_OBJ_NEW_SMALL_INT(get_open(self_in)->fd);
}
static MP_DEFINE_CONST_FUN_OBJ_1(socket_fileno_obj, socket_fileno);

static const mp_rom_map_elem_t socket_locals_dict_table[] = {
    { MP_ROM_QSTR(MP_QSTR___del__), MP_ROM_PTR(&mp_stream_close_obj) },
    { MP_ROM_QSTR(MP_QSTR_close), MP_ROM_PTR(&mp_stream_close_obj) },
    { MP_ROM_QSTR(MP_QSTR_fileno), MP_ROM_PTR(&socket_fileno_obj) },
    { MP_ROM_QSTR(MP_QSTR_getsockname), MP_ROM_PTR(&socket_getsockname_obj) },
    { MP_ROM_QSTR(MP_QSTR_connect), MP_ROM_PTR(&socket_connect_obj) },
    { MP_ROM_QSTR(MP_QSTR_bind), MP_ROM_PTR(&socket_bind_obj) },
    { MP_ROM_QSTR(MP_QSTR_listen), MP_ROM_PTR(&socket_listen_obj) },
    { MP_ROM_QSTR(MP_QSTR_send), MP_ROM_PTR(&socket_send_obj) },
    { MP_ROM_QSTR(MP_QSTR_recv), MP_ROM_PTR(&socket_recv_obj) },
    { MP_ROM_QSTR(MP_QSTR_sendto), MP_ROM_PTR(&socket_sendto_obj) },
    { MP_ROM_QSTR(MP_QSTR_recvfrom), MP_ROM_PTR(&socket_recvfrom_obj) },
    { MP_ROM_QSTR(MP_QSTR_setsockopt), MP_ROM_PTR(&socket_setsockopt_obj) },
    { MP_ROM_QSTR(MP_QSTR_setblocking), MP_ROM_PTR(&socket_setblocking_obj) },
    { MP_ROM_QSTR(MP_QSTR_settimeout), MP_ROM_PTR(&socket_settimeout_obj) },
    { MP_ROM_QSTR(MP_QSTR_read), MP_ROM_PTR(&mp_stream_read_obj) },
    { MP_ROM_QSTR(MP_QSTR_readinto), MP_ROM_PTR(&mp_stream_readinto_obj) },
    { MP_ROM_QSTR(MP_QSTR_readline), MP_ROM_PTR(&mp_stream_unbuffered_readline_obj) },
    { MP_ROM_QSTR(MP_QSTR_write), MP_ROM_PTR(&mp_stream_write_obj) },
};
static MP_DEFINE_CONST_DICT(socket_locals_dict, socket_locals_dict_table);

static const mp_stream_p_t socket_stream_p = {
    .read = socket_read,
    .write = socket_write,
    .ioctl = socket_ioctl,
};

static MP_DEFINE_CONST_OBJ_TYPE(
    socket_type,
    MP_QSTR_socket,
    MP_TYPE_FLAG_NONE,
    make_new, socket_make_new,
    protocol, &socket_stream_p,
    locals_dict, &socket_locals_dict
    );

// getaddrinfo(host, port, af=0, type=0, proto=0, flags=0) -> [(af, type, proto, '', sockaddr)]
static mp_obj_t mod_getaddrinfo(size_t n_args, const mp_obj_t *args) {
    const char *host = mp_obj_str_get_str(args[0]);
    char port[16];
    if (mp_obj_is_int(args[1])) {
        snprintf(port, sizeof(port), "%d", (int)mp_obj_get_int(args[1]));
    } else {
        snprintf(port, sizeof(port), "%s", mp_obj_str_get_str(args[1]));
    }
    struct addrinfo hints;
    memset(&hints, 0, sizeof(hints));
    hints.ai_family = n_args > 2 ? mp_obj_get_int(args[2]) : AF_INET;
    if (hints.ai_family == 0) {
        hints.ai_family = AF_INET;
    }
    hints.ai_socktype = n_args > 3 ? mp_obj_get_int(args[3]) : 0;
    hints.ai_protocol = n_args > 4 ? mp_obj_get_int(args[4]) : 0;
    hints.ai_flags = n_args > 5 ? mp_obj_get_int(args[5]) : 0;
    struct addrinfo *res;
    int r = getaddrinfo(host, port, &hints, &res);
    if (r != 0) {
        mp_raise_OSError(r == EAI_SYSTEM ? errno : MP_ENOENT);
    }
    mp_obj_t list = mp_obj_new_list(0, NULL);
    for (struct addrinfo *ai = res; ai != NULL; ai = ai->ai_next) {
        mp_obj_t t[5] = {
            MP_OBJ_NEW_SMALL_INT(ai->ai_family),
            MP_OBJ_NEW_SMALL_INT(ai->ai_socktype),
            MP_OBJ_NEW_SMALL_INT(ai->ai_protocol),
            MP_OBJ_NEW_QSTR(MP_QSTR_),
            mp_obj_new_bytes((const byte *)ai->ai_addr, ai->ai_addrlen),
        };
        mp_obj_list_append(list, mp_obj_new_tuple(5, t));
    }
    freeaddrinfo(res);
    return list;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(mod_getaddrinfo_obj, 2, 6, mod_getaddrinfo);

static const mp_rom_map_elem_t socket_module_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_socket) },
    { MP_ROM_QSTR(MP_QSTR_socket), MP_ROM_PTR(&socket_type) },
    { MP_ROM_QSTR(MP_QSTR_getaddrinfo), MP_ROM_PTR(&mod_getaddrinfo_obj) },
    { MP_ROM_QSTR(MP_QSTR_AF_INET), MP_ROM_INT(AF_INET) },
    { MP_ROM_QSTR(MP_QSTR_AF_INET6), MP_ROM_INT(AF_INET6) },
    { MP_ROM_QSTR(MP_QSTR_SOCK_STREAM), MP_ROM_INT(SOCK_STREAM) },
    { MP_ROM_QSTR(MP_QSTR_SOCK_DGRAM), MP_ROM_INT(SOCK_DGRAM) },
    { MP_ROM_QSTR(MP_QSTR_IPPROTO_TCP), MP_ROM_INT(IPPROTO_TCP) },
    { MP_ROM_QSTR(MP_QSTR_IPPROTO_UDP), MP_ROM_INT(IPPROTO_UDP) },
    { MP_ROM_QSTR(MP_QSTR_SOL_SOCKET), MP_ROM_INT(SOL_SOCKET) },
    { MP_ROM_QSTR(MP_QSTR_SO_REUSEADDR), MP_ROM_INT(SO_REUSEADDR) },
    { MP_ROM_QSTR(MP_QSTR_SO_BROADCAST), MP_ROM_INT(SO_BROADCAST) },
};
static MP_DEFINE_CONST_DICT(socket_module_globals, socket_module_globals_table);

const mp_obj_module_t mp_module_socket = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&socket_module_globals,
};

MP_REGISTER_MODULE(MP_QSTR_socket, mp_module_socket);
