# A board's wiring for App() in tests: no hardware, a fixed clock, a filesystem with room to spare.
import os

try:  # the App needs asyncio (the float32 build may lack it until it is built with it)
    import asyncio  # noqa: F401

    HAVE_ASYNCIO = True
except ImportError:
    HAVE_ASYNCIO = False


class Wiring:
    """The wiring App(wiring, cfg, ...) asks for, rooted at folder (made with its log folder)."""

    def __init__(self, folder):
        for d in (folder, folder + "/log"):
            try:
                os.mkdir(d)
            except OSError:
                pass
        self.log_dir = folder + "/log"
        self.state_path = folder + "/state.json"
        self.lines = []
        self.t = 0

    def ticks_ms(self):
        return self.t

    def rand(self, n=1):
        return 0

    def statvfs(self, path):
        return (4096, 4096, 10000, 9000, 9000, 0, 0, 0, 0, 255)

    def debug(self, text):
        self.lines.append(text)
