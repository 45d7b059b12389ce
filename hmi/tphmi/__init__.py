"""tphmi: the trackpilot HMI (display pages, buttons, LEDs/buzzer, remote box, command auth)."""
