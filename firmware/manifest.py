# Freeze trackpilot into a custom MicroPython firmware image (the modules then run from flash:
# no RAM to compile or load them). From a MicroPython checkout, e.g. for an ESP32-S3 N16R8:
#   TRACKPILOT_DIR=/path/to/trackpilot make -C ports/esp32 BOARD=ESP32_GENERIC_S3 \
#       BOARD_VARIANT=SPIRAM_OCT FROZEN_MANIFEST=/path/to/trackpilot/firmware/manifest.py
# boot.py and main.py stay on the filesystem (deploy copies them). Frozen modules are found before
# /lib: remove /lib/trackpilot and /lib/tphmi after switching. Not built in this repository's
# tests (that needs the ESP-IDF); check it when the first custom image is made.
import os

_tp = os.environ.get("TRACKPILOT_DIR", "$(MPY_DIR)/../trackpilot")
include("$(PORT_DIR)/boards/manifest.py")  # the port's own frozen modules (asyncio, ...)
package("trackpilot", base_path=_tp + "/firmware", opt=3)
package("tphmi", base_path=_tp + "/hmi", opt=3)
