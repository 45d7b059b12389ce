"""The board-facing code type-checked against the real MicroPython ESP32 API: boot.py, main.py and
every firmware/HMI module that imports machine, network or esp32, checked by basedpyright against
micropython-esp32-stubs (both pinned in requirements.txt). Zero errors; a misspelled keyword in a
machine call is caught."""
import importlib.metadata as md
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BOARD_IMPORT = re.compile(r"^\s*(import (machine|network|esp32)\b|from (machine|network|esp32) import)", re.M)


def board_files():
    files = [ROOT / "firmware" / "boot.py", ROOT / "firmware" / "main.py"]
    for d in ("firmware/trackpilot", "hmi/tphmi"):
        for p in sorted((ROOT / d).rglob("*.py")):
            if BOARD_IMPORT.search(p.read_text()):
                files.append(p)
    return files


def _checker():
    exe = Path(sys.executable).parent / "basedpyright"
    return str(exe) if exe.exists() else shutil.which("basedpyright")


def check(tmp_path, files):
    """Diagnostics (dicts) of basedpyright on files against the ESP32 stubs."""
    stubs = tmp_path / "stubs"
    for dist in ("micropython-esp32-stubs", "micropython-stdlib-stubs"):
        for f in md.files(dist):
            if f.suffix == ".pyi" or f.name == "VERSIONS":
                dst = stubs / str(f)
                dst.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy(f.locate(), dst)
    cfg = {
        "include": [str(f) for f in files],
        "typeshedPath": str(stubs),  # the stubs' MicroPython stdlib replaces CPython's typeshed
        "stubPath": str(stubs),  # machine, network, esp32 ...
        "extraPaths": [str(ROOT / "firmware"), str(ROOT / "hmi")],
        "typeCheckingMode": "standard",
        "pythonVersion": "3.10",
        "reportMissingModuleSource": "none",  # stubs without sources is the point
    }
    (tmp_path / "pyrightconfig.json").write_text(json.dumps(cfg))
    proc = subprocess.run([_checker(), "--outputjson", "-p", str(tmp_path / "pyrightconfig.json")],
                          capture_output=True, text=True, timeout=300)
    out = json.loads(proc.stdout)
    return [d for d in out["generalDiagnostics"] if d["severity"] == "error"], out["summary"]


def _fmt(diags):
    return "\n".join("%s:%d: %s" % (d["file"], d["range"]["start"]["line"] + 1, d["message"]) for d in diags)


def test_board_facing_code_has_no_type_errors(tmp_path):
    files = board_files()
    names = {p.name for p in files}
    assert {"boot.py", "main.py", "wiring_esp32.py"} <= names, names
    errors, summary = check(tmp_path, files)
    assert summary["filesAnalyzed"] >= len(files)
    assert errors == [], _fmt(errors)


def test_a_wrong_machine_call_is_caught(tmp_path):
    src = ("import machine\n\nuart = machine.UART(1, baudrate=4800, %s=1)\n"
           "pin = machine.Pin(4, machine.Pin.IN, machine.Pin.%s)\n")
    good = tmp_path / "good_board.py"
    good.write_text(src % ("timeout_char", "PULL_UP"))
    bad = tmp_path / "bad_board.py"
    bad.write_text(src % ("timeout_chars", "PULL_UPP"))
    errors, _ = check(tmp_path, [good, bad])
    assert {(Path(d["file"]).name, d["range"]["start"]["line"] + 1) for d in errors} == {
        ("bad_board.py", 3), ("bad_board.py", 4)}, _fmt(errors)
    assert "PULL_UPP" in _fmt(errors)
