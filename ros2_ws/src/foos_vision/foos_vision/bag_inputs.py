"""What track_video reads from bags, as the arrays the algorithms take: the rod joint states that pose the
figure mask (track_video --joint-states). What render_video films from a bag is read by foos_sim.camera.recorded."""
from __future__ import annotations

from foos_bag import BagError, read_joint_states, topics
from foos_core.names import JOINT_STATES_TOPIC

from .camera.figure_mask import JointStatesError, JointTrack, joint_track


def read_joint_track(bag: str) -> JointTrack:
    """The /joint_states of a bag as a JointTrack; JointStatesError with one line when the bag cannot give it."""
    source = f"--joint-states {bag}"
    try:
        available = topics(bag)
    except (BagError, OSError, ValueError) as error:
        raise JointStatesError(f"{source}: {error}") from None
    if JOINT_STATES_TOPIC not in available:
        raise JointStatesError(f"{source}: the bag has no {JOINT_STATES_TOPIC} topic "
                               f"(topics: {', '.join(sorted(available)) or 'none'})")
    try:
        states = read_joint_states(bag)
    except (BagError, OSError, ValueError) as error:
        raise JointStatesError(f"{source}: {error}") from None
    return joint_track(states.t, list(states.names), states.position, source)
