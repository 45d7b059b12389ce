"""The ESP32 board: pins and UARTs (wiring), Wi-Fi, maintenance/file transfer, the boot-loop guard."""
