# Runs the test_* functions of one test module under MicroPython and prints one line per test.
# Usage: micropython tests/mpy/_runner.py tests/mpy/test_geo.py
# Output: "ok NAME" or "FAIL NAME: message", then "N passed, M failed".
import sys


def _load(path):
    slash = path.rfind("/")
    folder = path[:slash] if slash >= 0 else "."
    name = path[slash + 1 :]
    if name.endswith(".py"):
        name = name[:-3]
    if folder not in sys.path:
        sys.path.insert(0, folder)
    return __import__(name)


def main():
    path = sys.argv[1]
    only = sys.argv[2] if len(sys.argv) > 2 else None
    mod = _load(path)
    names = sorted(n for n in dir(mod) if n.startswith("test_"))
    passed = failed = 0
    for n in names:
        if only and n != only:
            continue
        try:
            getattr(mod, n)()
            print("ok", n)
            passed += 1
        except Exception as e:  # report and keep going: one bad test must not hide others
            failed += 1
            print("FAIL", n + ":", repr(e))
            sys.print_exception(e)
    print("%d passed, %d failed" % (passed, failed))
    sys.exit(1 if failed or not passed else 0)


main()
