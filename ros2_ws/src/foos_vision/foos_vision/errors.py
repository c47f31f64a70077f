"""One exception type per kind of bad input, each carrying a one-line reason for the user.

A markers file and a camera description are read below the tracker (foos_core.markers,
foos_core.camera_model, shared with the simulated camera); their errors are named here too. All are
ValueErrors, which foos_core.command_line reports in one line.
"""
from foos_core.camera_model import CameraConfigError
from foos_core.markers import MarkersError

__all__ = ["VisionError", "VideoError", "MarkersError", "CameraConfigError"]


class VisionError(ValueError):
    """Bad input to a foos_vision tool: the message is the one line the user sees."""


class VideoError(VisionError):
    """A video that cannot be opened or decoded."""
