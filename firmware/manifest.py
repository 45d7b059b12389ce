# Freeze trackpilot into a custom MicroPython firmware image (the modules then run from flash:
# no RAM to compile or load them). From a MicroPython checkout, e.g. for an ESP32-S3 N16R8:
#   TRACKPILOT_DIR=/path/to/trackpilot make -C ports/esp32 BOARD=ESP32_GENERIC_S3 \
#       BOARD_VARIANT=SPIRAM_OCT FROZEN_MANIFEST=/path/to/trackpilot/firmware/manifest.py
# boot.py and main.py stay on the filesystem (deploy copies them). Frozen modules are found before
# /lib: remove /lib/trackpilot and /lib/tphmi after switching. Not built in this repository's
# tests (that needs the ESP-IDF); check it when the first custom image is made.
# Only what the board runs is frozen: the file lists below are the modules `trackpilot deploy`
# copies (no trackpilot/sim, no tphmi/preview); a test checks they are current.
import os

_tp = os.environ.get("TRACKPILOT_DIR", "$(MPY_DIR)/../trackpilot")
# --- board modules (trackpilot deploy --update-package-json writes this block) ---
_TPHMI_FILES = ['__init__.py', 'auth.py', 'board.py', 'buttons.py', 'indicators.py', 'pages.py', 'remote.py', 'ssd1306.py', 'status.py']
_TRACKPILOT_FILES = ['__init__.py', 'app.py', 'board/__init__.py', 'board/bootguard.py', 'board/maint.py', 'board/wifi.py', 'board/wiring_esp32.py', 'board/xfer.py', 'compat.py', 'config.py', 'core/__init__.py', 'core/autopilot.py', 'core/control.py', 'core/modes.py', 'core/pilotdb.py', 'core/pilotwatch.py', 'core/trial.py', 'devices/__init__.py', 'devices/gnss.py', 'devices/motor.py', 'devices/mwv.py', 'devices/nmea.py', 'devices/nmea_out.py', 'devices/ntrip.py', 'devices/seatalk.py', 'devices/st2000.py', 'devices/stlink.py', 'devices/ubxcfg.py', 'nav/__init__.py', 'nav/deadreckon.py', 'nav/fix.py', 'nav/geo.py', 'nav/guidance.py', 'nav/pilotgain.py', 'nav/progress.py', 'nav/swing.py', 'nav/tauest.py', 'nav/tighten.py', 'nav/track.py', 'nav/turnwatch.py', 'record/__init__.py', 'record/logfmt.py', 'record/logger.py']
# --- end of board modules ---
include("$(PORT_DIR)/boards/manifest.py")  # the port's own frozen modules (asyncio, ...)
package("trackpilot", files=_TRACKPILOT_FILES, base_path=_tp + "/firmware", opt=3)
package("tphmi", files=_TPHMI_FILES, base_path=_tp + "/hmi", opt=3)
