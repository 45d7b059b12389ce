"""pytest glue: every tests/mpy/test_*.py runs under the MicroPython unix port ($MICROPYTHON)."""
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "host_tools"))

from trackpilot_tools.mpy import micropython_cmd, micropython_env  # noqa: E402


def pytest_configure(config):
    config.addinivalue_line("markers", "mpy: runs firmware code under the MicroPython unix port")


def pytest_pycollect_makemodule(module_path, parent):
    """tests/mpy/test_*.py are MicroPython scripts: run them, do not import them into CPython."""
    if module_path.parent.name == "mpy":
        return MpyFile.from_parent(parent, path=module_path)
    return None


class MpyFile(pytest.File):
    def collect(self):
        yield MpyItem.from_parent(self, name=self.path.stem)


class MpyItem(pytest.Item):
    def __init__(self, **kw):
        super().__init__(**kw)
        self.add_marker(pytest.mark.mpy)

    def runtest(self):
        import subprocess

        runner = ROOT / "tests" / "mpy" / "_runner.py"
        proc = subprocess.run(
            micropython_cmd() + [str(runner), str(self.path)],
            cwd=str(ROOT),
            env=micropython_env(),
            capture_output=True,
            text=True,
            timeout=float(os.environ.get("TRACKPILOT_MPY_TIMEOUT", "900")),
        )
        if proc.returncode != 0:
            raise MpyFailure(proc.stdout + proc.stderr)

    def repr_failure(self, excinfo):
        if isinstance(excinfo.value, MpyFailure):
            return "MicroPython test file failed (%s):\n%s" % (" ".join(micropython_cmd()), excinfo.value)
        return super().repr_failure(excinfo)

    def reportinfo(self):
        return self.path, 0, "mpy: %s" % self.name


class MpyFailure(Exception):
    pass
