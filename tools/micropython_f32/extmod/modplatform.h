// trackpilot f32 port: stand-in for MicroPython's extmod/modplatform.h, which py/modsys.c
// includes but the sdist does not ship.  This port sets MICROPY_BANNER_MACHINE itself, so
// none of the platform-name macros are needed.
#ifndef MICROPY_INCLUDED_EXTMOD_MODPLATFORM_H
#define MICROPY_INCLUDED_EXTMOD_MODPLATFORM_H
#endif
