"""The detection stage: the ball's candidates in one frame, judged by the candidate rules, and the searches the
tracker runs (near a SearchWindow it fills in, elsewhere, the whole field). Imports the camera stage, never tracking.
"""
