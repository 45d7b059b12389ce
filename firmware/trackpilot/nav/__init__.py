"""Navigation: positions (integers in 1e-7 deg), tracks, progress along them, guidance laws, dead reckoning."""
