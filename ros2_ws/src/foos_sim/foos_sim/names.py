"""Names fixed by the contract (shared/CONTRACT.md): teams, rods, joints and the command layout."""

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
