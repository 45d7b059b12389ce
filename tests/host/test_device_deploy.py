"""deploy --dry-run: every firmware and HMI module compiles with mpy-cross, and the unix-port
micropython imports the .mpy files (not the sources); package.json lists every module."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

from trackpilot_tools import device_cmd  # noqa: E402
from trackpilot_tools.mpy import micropython_cmd  # noqa: E402

pytestmark = pytest.mark.mpy  # runs the firmware under $MICROPYTHON (so make test's 32-bit pass too)


def test_dry_run_builds_importable_mpy(tmp_path):
    out = tmp_path / "deploy"
    p = subprocess.run([sys.executable, "-m", "trackpilot_tools.cli", "deploy", "--dry-run", "--out", str(out)],
                       capture_output=True, text=True, env={"PYTHONPATH": str(ROOT / "host_tools"), "PATH": ""})
    assert p.returncode == 0, p.stderr
    srcs = device_cmd.sources()
    for pkg, src in srcs:
        assert (out / "lib" / pkg / (src.stem + ".mpy")).stat().st_size > 0
    # nothing of the simulator, the bench or the HMI previews goes on the board
    built = sorted(str(q.relative_to(out / "lib")) for q in (out / "lib").rglob("*.mpy"))
    for host_only in ("simio", "wiring_sim", "motor_sim", "wiring_bench", "samples", "render_cli"):
        assert not [b for b in built if b.endswith("/%s.mpy" % host_only)], (host_only, built)
    assert not (out / "lib" / "trackpilot" / "sim").exists() and not (out / "lib" / "tphmi" / "preview").exists()
    assert (out / "main.py").read_text() == (ROOT / "firmware" / "main.py").read_text()
    pkg = json.loads((out / "package.json").read_text())
    assert len(pkg["urls"]) == len(srcs)
    code = ("import sys; sys.path.clear(); sys.path.append(%r)\n"
            "import trackpilot.core.modes as M, trackpilot.board.maint, trackpilot.board.xfer, tphmi.status\n"
            "print(M.__file__, trackpilot.board.xfer.__file__, M.MODE_NAMES[M.ModeMachine().mode])\n"
            % str(out / "lib"))
    r = subprocess.run(micropython_cmd() + ["-c", code], capture_output=True, text=True, cwd=str(tmp_path),
                       env={"MICROPYPATH": str(out / "lib")})
    assert r.returncode == 0, r.stdout + r.stderr
    files = r.stdout.split()
    assert files[0].endswith("trackpilot/core/modes.mpy") and files[1].endswith("trackpilot/board/xfer.mpy")
    assert files[2] == "STANDBY"


def test_mpy_version_decoding():
    # unix x64 port of MicroPython 1.29: _mpy 2822 = v6.3, arch 2 (x64)
    assert device_cmd.device_mpy_version(2822) == (6, 3, 2)
    assert device_cmd.mpy_cross_version() == (6, 3)


def test_firmware_package_json_lists_every_module():
    # `mpremote mip install firmware/package.json` installs the sources; it must not go stale
    pkg = json.loads((ROOT / "firmware" / "package.json").read_text())
    targets = sorted(t for t, _ in pkg["urls"])
    want = sorted("%s/%s" % (p, s.name) for p, s in device_cmd.sources())
    assert targets == want, "regenerate firmware/package.json (docs/DEVICE.md)"
    for target, src in pkg["urls"]:
        assert (ROOT / "firmware" / src).resolve().is_file(), src


def test_manifest_freezes_what_deploy_copies():
    # firmware/manifest.py freezes the board's modules only: the same list as deploy, none of the
    # simulator's, bench's or HMI previews' modules
    ns = {}
    text = (ROOT / "firmware" / "manifest.py").read_text()
    block = text.split(device_cmd.MANIFEST_BEGIN)[1].split(device_cmd.MANIFEST_END)[0]
    exec(block, ns)
    assert {"trackpilot": ns["_TRACKPILOT_FILES"], "tphmi": ns["_TPHMI_FILES"]} == device_cmd.manifest_files(), \
        "regenerate with trackpilot deploy --update-package-json"
    frozen = ns["_TRACKPILOT_FILES"] + ns["_TPHMI_FILES"]
    assert "app.py" in frozen and "core/modes.py" in frozen
    assert not [f for f in frozen if f.startswith(("sim/", "preview/"))]
