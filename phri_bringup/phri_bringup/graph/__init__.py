"""The node graph (pure): what launch files and sessions start, parameter files, preflight."""
