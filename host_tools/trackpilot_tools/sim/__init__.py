"""The host simulator: a simulated boat, its devices and its water, driving the real firmware
under the MicroPython unix port through the stepping protocol (docs/SIM_PROTOCOL.md).

Modules: params (parameters), randproc (seeded random processes), geodesy (local frame <-> lat/lon),
boat (dynamics and environment), ubx/nmea_enc (own encoders), f9p (ZED-F9P), stcodec (own SeaTalk
codec), st2000_sim (the tiller pilot), seatalk_bus (the bus), wind_sensor (MWV), motor_dev (the
motor controller), scenarios (presets and faults), truth (metrics from the truth), runner (lockstep
driver), plots. See docs/SIMULATOR.md.
"""
