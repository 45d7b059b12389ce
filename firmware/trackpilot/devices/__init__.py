"""Device drivers and parsers: bytes in, records and actions out (no I/O of their own)."""
