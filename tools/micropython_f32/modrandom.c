// trackpilot f32 port: `random` module (extmod/ is not in the sdist, so this is our own).
// Same generator, seeding and range reduction as MicroPython's random module, so a seeded
// sequence of getrandbits/randrange/randint/choice values equals the unix port's. random()
// takes 23 bits from one generator step, as a single-precision MicroPython build does.
#include <fcntl.h>
#include <time.h>
#include <unistd.h>

#include "py/runtime.h"
#include "py/smallint.h"

#if MICROPY_PY_RANDOM

// Generator state (yasmarang: pad, n, d and an 8-bit dat).
static uint32_t rnd_pad = 0xeda4baba, rnd_n = 69, rnd_d = 233;
static uint8_t rnd_dat;
static bool rnd_seeded;

static void rnd_seed(uint32_t s) {
    rnd_pad = s;
    rnd_n = 69;
    rnd_d = 233;
    rnd_dat = 0;
    rnd_seeded = true;
}

static uint32_t rnd_entropy(void) {
    uint32_t s = 0;
    int fd = open("/dev/urandom", O_RDONLY);
    if (fd >= 0) {
        if (read(fd, &s, sizeof(s)) != sizeof(s)) {
            s = 0;
        }
        close(fd);
    }
    if (s == 0) {
        s = (uint32_t)time(NULL) ^ ((uint32_t)getpid() << 16);
    }
    return s;
}

static uint32_t rnd_next(void) {
    if (!rnd_seeded) {
        rnd_seed(rnd_entropy());
    }
    rnd_pad += rnd_dat + rnd_d * rnd_n;
    rnd_pad = (rnd_pad << 3) + (rnd_pad >> 29);
    rnd_n = rnd_pad | 2;
    rnd_d ^= (rnd_pad << 31) + (rnd_pad >> 1);
    rnd_dat ^= (uint8_t)(rnd_pad ^ (rnd_d >> 8) ^ 1);
    return rnd_pad ^ (rnd_d << 5) ^ (rnd_pad >> 18) ^ ((uint32_t)rnd_dat << 1);
}

// Uniform in [0, n): mask to the next power of two and retry until below n.  Ranges wider
// than 32 bits raise ValueError (the unix port loops forever on them; on the ESP32 such ints
// don't fit mp_int_t anyway). Arithmetic in long long: the same results on a 32-bit build.
static mp_obj_t new_int_ll(long long v) {
    if (v >= MP_SMALL_INT_MIN && v <= MP_SMALL_INT_MAX) {
        return MP_OBJ_NEW_SMALL_INT((mp_int_t)v);
    }
    return mp_obj_new_int_from_ll(v);
}

static uint32_t rnd_below(long long n_in) {
    if (n_in > 0xffffffffLL) {
        if (n_in - 1 == 0xffffffffLL) {
            return rnd_next(); // all 32 bits
        }
        mp_raise_ValueError(MP_ERROR_TEXT("range too large"));
    }
    uint32_t n = (uint32_t)n_in;
    uint32_t mask = 1;
    while ((n & mask) < n) {
        mask = (mask << 1) | 1;
    }
    uint32_t r;
    do {
        r = rnd_next() & mask;
    } while (r >= n);
    return r;
}

static mp_obj_t mod_random_getrandbits(mp_obj_t n_in) {
    mp_int_t n = mp_obj_get_int(n_in);
    if (n < 0 || n > 32) {
        mp_raise_ValueError(MP_ERROR_TEXT("bits must be 32 or less"));
    }
    if (n == 0) {
        return MP_OBJ_NEW_SMALL_INT(0);
    }
    uint32_t mask = n == 32 ? 0xffffffff : ((uint32_t)1 << n) - 1;
    return mp_obj_new_int_from_uint(rnd_next() & mask);
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_random_getrandbits_obj, mod_random_getrandbits);

static mp_obj_t mod_random_seed(size_t n_args, const mp_obj_t *args) {
    if (n_args == 0 || args[0] == mp_const_none) {
        rnd_seed(rnd_entropy());
    } else {
        rnd_seed((uint32_t)mp_obj_get_int_truncated(args[0]));
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(mod_random_seed_obj, 0, 1, mod_random_seed);

static mp_obj_t mod_random_randrange(size_t n_args, const mp_obj_t *args) {
    long long start = mp_obj_get_ll(args[0]);
    if (n_args == 1) {
        if (start > 0) {
            return new_int_ll(rnd_below(start));
        }
        mp_raise_ValueError(NULL);
    }
    long long stop = mp_obj_get_ll(args[1]);
    if (n_args == 2) {
        if (start < stop) {
            return new_int_ll(start + (long long)rnd_below(stop - start));
        }
        mp_raise_ValueError(NULL);
    }
    long long step = mp_obj_get_ll(args[2]);
    long long n;
    if (step > 0) {
        n = (stop - start + step - 1) / step;
    } else if (step < 0) {
        n = (stop - start + step + 1) / step;
    } else {
        mp_raise_ValueError(NULL);
    }
    if (n <= 0) {
        mp_raise_ValueError(NULL);
    }
    return new_int_ll(start + step * (long long)rnd_below(n));
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(mod_random_randrange_obj, 1, 3, mod_random_randrange);

static mp_obj_t mod_random_randint(mp_obj_t a_in, mp_obj_t b_in) {
    long long a = mp_obj_get_ll(a_in);
    long long b = mp_obj_get_ll(b_in);
    if (a > b) {
        mp_raise_ValueError(NULL);
    }
    return new_int_ll(a + (long long)rnd_below(b - a + 1));
}
static MP_DEFINE_CONST_FUN_OBJ_2(mod_random_randint_obj, mod_random_randint);

static mp_obj_t mod_random_choice(mp_obj_t seq) {
    mp_int_t len = mp_obj_get_int(mp_obj_len(seq));
    if (len <= 0) {
        mp_raise_type(&mp_type_IndexError);
    }
    return mp_obj_subscr(seq, mp_obj_new_int(rnd_below(len)), MP_OBJ_SENTINEL);
}
static MP_DEFINE_CONST_FUN_OBJ_1(mod_random_choice_obj, mod_random_choice);

// [0, 1): 23 random mantissa bits under an exponent of 0, minus one.
static mp_float_t rnd_float(void) {
    union {
        float f;
        uint32_t i;
    } u;
    u.i = (rnd_next() >> 9) | 0x3f800000;
    return (mp_float_t)(u.f - 1.0f);
}

static mp_obj_t mod_random_random(void) {
    return mp_obj_new_float(rnd_float());
}
static MP_DEFINE_CONST_FUN_OBJ_0(mod_random_random_obj, mod_random_random);

static mp_obj_t mod_random_uniform(mp_obj_t a_in, mp_obj_t b_in) {
    mp_float_t a = mp_obj_get_float(a_in);
    mp_float_t b = mp_obj_get_float(b_in);
    return mp_obj_new_float(a + (b - a) * rnd_float());
}
static MP_DEFINE_CONST_FUN_OBJ_2(mod_random_uniform_obj, mod_random_uniform);

static const mp_rom_map_elem_t mp_module_random_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_random) },
    { MP_ROM_QSTR(MP_QSTR_getrandbits), MP_ROM_PTR(&mod_random_getrandbits_obj) },
    { MP_ROM_QSTR(MP_QSTR_seed), MP_ROM_PTR(&mod_random_seed_obj) },
    { MP_ROM_QSTR(MP_QSTR_randrange), MP_ROM_PTR(&mod_random_randrange_obj) },
    { MP_ROM_QSTR(MP_QSTR_randint), MP_ROM_PTR(&mod_random_randint_obj) },
    { MP_ROM_QSTR(MP_QSTR_choice), MP_ROM_PTR(&mod_random_choice_obj) },
    { MP_ROM_QSTR(MP_QSTR_random), MP_ROM_PTR(&mod_random_random_obj) },
    { MP_ROM_QSTR(MP_QSTR_uniform), MP_ROM_PTR(&mod_random_uniform_obj) },
};
static MP_DEFINE_CONST_DICT(mp_module_random_globals, mp_module_random_globals_table);

const mp_obj_module_t mp_module_random = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&mp_module_random_globals,
};

MP_REGISTER_EXTENSIBLE_MODULE(MP_QSTR_random, mp_module_random);

#endif // MICROPY_PY_RANDOM
