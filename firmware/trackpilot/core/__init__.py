"""The decision core: the mode machine, the control step and the autopilot that joins them."""
