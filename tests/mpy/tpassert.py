# Small assertion helpers for tests that run under MicroPython (no pytest there).


def eq(a, b, msg=""):
    if a != b:
        raise AssertionError("%r != %r %s" % (a, b, msg))


def near(a, b, tol, msg=""):
    if abs(a - b) > tol:
        raise AssertionError("|%r - %r| > %r %s" % (a, b, tol, msg))


def true(c, msg=""):
    if not c:
        raise AssertionError(msg or "expected true")


def raises(exc, fn, *args, **kw):
    try:
        fn(*args, **kw)
    except exc as e:
        return e
    raise AssertionError("%s not raised" % exc.__name__)
