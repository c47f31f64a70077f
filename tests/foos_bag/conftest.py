"""pytest fixtures of the bag tests; the helpers live in helpers.py."""
from .helpers import launch  # noqa: F401  (the fixture)
