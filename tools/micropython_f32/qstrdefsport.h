// qstrs specific to this port (none: all are collected automatically)
