# trackpilot firmware package (MicroPython; also runs unchanged under the unix port).
VERSION = "0.1.0"
