// trackpilot f32 port: HAL declarations.
#include <unistd.h>

#define mp_hal_stdio_poll(poll_flags) (0)
static inline void mp_hal_set_interrupt_char(char c) {
    (void)c;
}
static inline void mp_hal_delay_us(mp_uint_t us) {
    usleep(us);
}
static inline void mp_hal_delay_ms(mp_uint_t ms) {
    usleep(ms * 1000);
}
static inline mp_uint_t mp_hal_ticks_cpu(void) {
    return 0;
}

// No machine.Pin here: defining the pin type stops py/mphal.h pulling in extmod/virtpin.h.
#define mp_hal_pin_obj_t mp_obj_t

// fileio.c: readiness of a file descriptor for MP_STREAM_POLL (files and sockets share it)
mp_uint_t f32_fd_poll(int fd, uintptr_t arg, int *errcode);
