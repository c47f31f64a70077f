"""pytest fixtures of the bag tests; the helpers live in bag_helpers.py (a name no other area uses)."""
from bag_helpers import launch  # noqa: F401  (the fixture)
