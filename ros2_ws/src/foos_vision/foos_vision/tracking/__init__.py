"""The tracking stage: association of a frame's candidates with the track, the Kalman filter, the offline backward
pass (backfill). Imports camera and detection; the shells (CLI, node, benches) import it.
"""
