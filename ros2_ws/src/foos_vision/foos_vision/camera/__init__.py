"""The camera stage: the lens, the tags or the field's corners, then the mapping between image pixels and the ball
plane (FieldView), with the rods and figures as the camera sees them. Imports nothing else of foos_vision but errors.
"""
