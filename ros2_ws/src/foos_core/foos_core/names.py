"""Names fixed by the contract (shared/CONTRACT.md): teams, rods, joints, the command layout and the
model's geom names."""
from __future__ import annotations

TEAMS = ("home", "away")
RODS = ("goalie", "defence", "midfield", "attack")
AXES = ("slide", "rotate")

# One rod command: [goalie_slide, goalie_rotate, defence_slide, ..., attack_rotate].
COMMAND_SIZE = len(RODS) * len(AXES)


def joint_name(team: str, rod: str, axis: str) -> str:
    return f"{team}_{rod}_{axis}"


def team_joint_names(team: str) -> tuple[str, ...]:
    """The 8 joints of one team in command order."""
    return tuple(joint_name(team, rod, axis) for rod in RODS for axis in AXES)


# The 16 joints in the order of /joint_states and of the model's actuators: home then away.
JOINT_NAMES = tuple(name for team in TEAMS for name in team_joint_names(team))

BALL_BODY = "ball"
BALL_JOINT = "ball"
FIELD_GEOM = "field"
WALL_PREFIX = "wall"


def rod_name(team: str, rod: str) -> str:
    """The rod's body (and its geoms' prefix) in the model: `home_attack`."""
    return f"{team}_{rod}"


# A figure's geoms are `{team}_{rod}_figure{i}_{part}`, part `body` or `foot` (foos_sim.model_builder
# writes them; the RL env counts touches and the tracker masks figures by these names).
FIGURE_INFIX = "_figure"
FIGURE_PARTS = ("body", "foot")


def figure_geom_name(team: str, rod: str, index: int, part: str) -> str:
    return f"{rod_name(team, rod)}{FIGURE_INFIX}{index}_{part}"


def is_figure_geom(name: str) -> bool:
    return FIGURE_INFIX in name


def figure_team(name: str) -> str | None:
    """The team whose figure a geom is part of, or None for any other geom."""
    if not is_figure_geom(name):
        return None
    team = name.split("_", 1)[0]
    return team if team in TEAMS else None


# Topics (shared/CONTRACT.md) and the frame every position is in.
TABLE_FRAME = "table"
BALL_FRAME = "ball"  # child frame of /ball/state
CAMERA_FRAME = "camera"  # frame of /camera/image_raw (the simulated camera's; a real driver names its own)
JOINT_STATES_TOPIC = "/joint_states"
BALL_DETECTION_TOPIC = "/ball/detection"
BALL_STATE_TOPIC = "/ball/state"
CAMERA_IMAGE_TOPIC = "/camera/image_raw"
CAMERA_INFO_TOPIC = "/camera/camera_info"
CLOCK_TOPIC = "/clock"
GOAL_TOPIC = "/sim/goal"  # sim_node's own: the team that scored (std_msgs/String); not in the contract
# sim_node's true ball (nav_msgs/Odometry) while its camera is on and a tracker publishes /ball/state (contract)
SIM_BALL_STATE_TOPIC = "/sim/ball/state"


def command_topic(team: str) -> str:
    """`/home/rods/command`: the team's 8 rod velocity targets (std_msgs/Float64MultiArray)."""
    return f"/{team}/rods/command"
