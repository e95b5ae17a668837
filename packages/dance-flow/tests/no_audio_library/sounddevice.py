"""Stands in for a machine without the ``sounddevice`` library (or without PortAudio, which it loads on import)."""

raise ImportError("PortAudio library not found")
