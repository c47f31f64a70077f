"""One exception type per kind of bad input, each carrying a one-line reason for the user."""


class VisionError(Exception):
    """Bad input to a foos_vision tool: the message is the one line the user sees."""


class MarkersError(VisionError):
    """A markers file that is missing, malformed, or does not match the tags in the video."""


class VideoError(VisionError):
    """A video that cannot be opened or decoded."""


class CameraConfigError(VisionError):
    """A camera configuration or intrinsics file that cannot describe a camera."""
