"""The live scene without ROS: a real Foxglove WebSocket server (LiveScene) and a client that decodes what
it gets with the schemas the server advertises. Expected figure poses are computed here from the parameter
file, not from the model the viewer draws."""
import math
import time

import numpy as np
import pytest

from foos_core.names import JOINT_NAMES, RODS, TEAMS, rod_name
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import ParamsError, load_params
from foos_viewer.live import (
    BALL_TOPIC,
    DETECTIONS_TOPIC,
    RODS_TOPIC,
    SCENE_TOPICS,
    TABLE_TOPIC,
    LiveScene,
    ViewerError,
)
from foos_viewer.scene import TableScene, rod_entity_id

from .helpers import FoxgloveClient, decoded, entities, metadata, xyz


def expected_foot_centres(params: dict, team: str, rod: str, slide: float, rotate: float) -> np.ndarray:
    """Centre of each figure's foot in the table frame: the foot hangs below the rod axis and swings about +x
    (+rotate: toward +y), the rod slides along +x (shared/CONTRACT.md)."""
    layout, figure, rods = params["rods"]["layout"][rod_name(team, rod)], params["figure"], params["rods"]
    reach = rods["axis_height"] - figure["foot_clearance"] - figure["foot_size"][2] / 2
    n = int(layout["figures"])
    return np.array([((i - (n - 1) / 2) * layout["spacing"] + slide, layout["y"] + reach * math.sin(rotate),
                      rods["axis_height"] - reach * math.cos(rotate)) for i in range(n)])


def feet(entity) -> np.ndarray:
    """The foot boxes of a rod entity: its cubes are each figure's body then foot."""
    return np.array([xyz(cube.pose.position) for cube in entity.cubes[1::2]])


@pytest.fixture(scope="module")
def scene():
    return TableScene()


@pytest.fixture
def live(scene):
    served = LiveScene(scene, port=0, max_rate=30.0)
    yield served
    served.close()


@pytest.fixture
def client(live):
    connected = FoxgloveClient(live.url)
    yield connected
    connected.close()


def latest(live, client, topic, since=-math.inf, timeout=10.0):
    """The newest update on topic since a time, flushing as scene_node's timer does while waiting."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        live.flush()
        got = client.messages(topic, since)
        if got:
            return got[-1][1]
        time.sleep(0.01)
    raise AssertionError(f"no update on {topic} within {timeout} s")


def test_a_subscriber_gets_the_table_and_22_figures_on_8_rods_posed_from_the_joints(live, client):
    client.subscribe(SCENE_TOPICS)
    params, geometry = load_params(), TableGeometry.nominal()
    table = entities(latest(live, client, TABLE_TOPIC))["table"]
    assert table.frame_id == "table"
    field = max(table.cubes, key=lambda cube: cube.size.x * cube.size.y)
    assert (field.size.x, field.size.y) == pytest.approx((2 * geometry.half_width, 2 * geometry.half_length))
    assert len(table.cubes) >= 17, "field, two goal floors and the walls"
    rods = entities(latest(live, client, RODS_TOPIC), "rod/")
    assert sorted(rods) == sorted(rod_entity_id(team, rod) for team in TEAMS for rod in RODS)
    figures = {key: len(entity.cubes) // 2 for key, entity in rods.items()}
    assert sum(figures.values()) == 22
    for team in TEAMS:
        for rod in RODS:
            entity = rods[rod_entity_id(team, rod)]
            assert figures[rod_entity_id(team, rod)] == params["rods"]["layout"][rod_name(team, rod)]["figures"]
            assert len(entity.cylinders) == 1
            assert feet(entity) == pytest.approx(expected_foot_centres(params, team, rod, 0.0, 0.0), abs=1e-9)

    # A message naming the joints in another order, some of them only: by name, and the others stay.
    started = time.monotonic()
    live.set_joints(["home_attack_rotate", "home_attack_slide"], [0.7, 0.05], (12, 5))
    live.flush(time.monotonic() + 1.0)
    rods = entities(latest(live, client, RODS_TOPIC, since=started), "rod/")
    moved = rods[rod_entity_id("home", "attack")]
    assert metadata(moved) == {"slide": "0.050000", "rotate": "0.700000", "stamp": "12.000000005"}
    assert feet(moved) == pytest.approx(expected_foot_centres(params, "home", "attack", 0.05, 0.7), abs=1e-9)
    still = rods[rod_entity_id("away", "defence")]
    assert feet(still) == pytest.approx(expected_foot_centres(params, "away", "defence", 0.0, 0.0), abs=1e-9)
    # A non-finite joint value keeps the joint where it was.
    started = time.monotonic()
    live.set_joints(list(JOINT_NAMES), [math.nan] * 16, (13, 0))
    live.flush(time.monotonic() + 2.0)
    moved = entities(latest(live, client, RODS_TOPIC, since=started), "rod/")[rod_entity_id("home", "attack")]
    assert feet(moved) == pytest.approx(expected_foot_centres(params, "home", "attack", 0.05, 0.7), abs=1e-9)


def test_ball_and_detections_are_separate_entities_and_the_trail_keeps_its_seconds(live, client):
    client.subscribe([BALL_TOPIC, DETECTIONS_TOPIC])
    live.set_ball((0.1, -0.2, 0.0175), (1.0, 0.0, 0.0), (3, 250_000_000))
    ball = entities(latest(live, client, BALL_TOPIC))["ball"]
    assert xyz(ball.spheres[0].pose.position) == pytest.approx((0.1, -0.2, 0.0175))
    assert ball.spheres[0].size.x == pytest.approx(0.035)
    assert metadata(ball)["stamp"] == "3.250000000"
    assert len(ball.arrows) == 1 and ball.arrows[0].shaft_length + ball.arrows[0].head_length == pytest.approx(0.1)
    # 1 s of detections at 100 Hz; the trail holds the last 0.5 s of stamps.
    for i in range(100):
        live.add_detection((0.001 * i, 0.0, 0.0175), (5, i * 10_000_000), now=0.0)
    live.flush(time.monotonic() + 10.0)
    detections = entities(latest(live, client, DETECTIONS_TOPIC))["detections"]
    assert xyz(detections.spheres[0].pose.position) == pytest.approx((0.099, 0.0, 0.0175))
    assert metadata(detections)["stamp"] == "5.990000000"
    assert len(detections.lines[0].points) == 51
    # Time going back (a new run) starts the trail again.
    started = time.monotonic()
    live.add_detection((0.3, 0.3, 0.0175), (0, 0), now=time.monotonic() + 20.0)
    detections = entities(latest(live, client, DETECTIONS_TOPIC, since=started))["detections"]
    assert metadata(detections)["points"] == "1" and not detections.lines


def test_updates_are_held_to_max_rate_and_the_last_state_still_goes_out(scene):
    live = LiveScene(scene, port=0, max_rate=20.0)
    client = FoxgloveClient(live.url)
    try:
        client.subscribe([BALL_TOPIC])
        time.sleep(0.3)  # the subscription reaches the server
        start = time.monotonic()
        i = 0
        while time.monotonic() - start < 2.0:  # 200 Hz of /ball/state for 2 s
            live.set_ball((0.0001 * i, 0.0, 0.0175), (0.0, 0.0, 0.0), (0, i))
            i += 1
            time.sleep(0.005)
        for _ in range(10):  # what scene_node's timer does
            live.flush()
            time.sleep(0.025)
        got = client.messages(BALL_TOPIC, since=start)
        assert 36 <= len(got) <= 42, f"{len(got)} updates in 2 s at max_rate 20"
        assert metadata(entities(got[-1][1])["ball"])["stamp"] == f"0.{i - 1:09d}"
    finally:
        client.close()
        live.close()


def test_a_non_regulation_table_is_drawn_from_its_params_file(tmp_path):
    path = tmp_path / "wide.yaml"
    path.write_text("base: regulation_table\nfield: {length: 1.187, width: 0.673}\n")
    scene = TableScene(path)
    table = decoded(scene.table_entity(0))
    field = max(table.cubes, key=lambda cube: cube.size.x * cube.size.y)
    assert (field.size.x, field.size.y) == pytest.approx((0.673, 1.187))
    walls = [cube for cube in table.cubes if cube.size.x < 0.05 and cube.size.y > 1.0]
    assert sorted(cube.pose.position.x for cube in walls) == pytest.approx([-0.673 / 2 - 0.015, 0.673 / 2 + 0.015])


def test_bad_inputs_are_one_line_errors(scene, tmp_path):
    with pytest.raises(ParamsError, match="parameter file not found"):
        TableScene(tmp_path / "missing.yaml")
    live = LiveScene(scene, port=0)
    try:
        with pytest.raises(ViewerError, match=f"cannot serve Foxglove WebSocket on 127.0.0.1:{live.port}: .*in use"):
            LiveScene(scene, port=live.port)
        with pytest.raises(ValueError, match="non-finite"):
            live.set_ball((math.nan, 0.0, 0.0), (0.0, 0.0, 0.0), (0, 0))
    finally:
        live.close()
    with pytest.raises(ViewerError, match="port must be in 0-65535"):
        LiveScene(scene, port=70000)
    with pytest.raises(ViewerError, match="max_rate must be positive"):
        LiveScene(scene, port=0, max_rate=0.0)
