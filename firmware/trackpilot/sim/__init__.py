"""Simulation and bench adapters: never deployed to the board (trackpilot deploy skips this folder)."""
