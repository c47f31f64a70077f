"""The simulated camera's bad inputs (a scene, a bag to film, a render's options): one line for the user."""


class RenderError(ValueError):
    """Bad input to the simulated camera or render_video: the message is the one line the user sees."""
