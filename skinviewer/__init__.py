"""skinviewer: interactive tuning of real-time human-skin shaders with a headless pass-graph core."""
__version__ = "0.1.0"
