"""The table as a camera sees it: foos_sim's MJCF plus ArUco tags, a table frame, and a camera.

Nothing of foos_sim is changed: the MJCF text is taken from `foos_sim.build_mjcf` and extended here.
The physics of the extended model is the same (the added geoms do not collide), so a TableSimulation
can be stepped on it directly.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

import cv2
import mujoco
import numpy as np

from foos_core.camera_model import CameraConfig
from foos_core.markers import MarkerLayout

from .hands import add_hand

CAMERA_NAME = "vision_cam"
TAG_TEXTURE_PIXELS = 8  # texels per ArUco cell: crisp edges for the tag detector at any render size
TAG_QUIET_CELLS = 1  # white border around the black square, in cells, as printed tags have


def _fmt(*values: float) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def tag_texture(layout: MarkerLayout, tag_id: int) -> tuple[np.ndarray, float]:
    """RGB image of a printed tag with its white border, and the printed edge length in metres."""
    dictionary = layout.aruco_dictionary()
    cells = dictionary.markerSize + 2  # data bits plus the black border
    side = cells * TAG_TEXTURE_PIXELS
    marker = cv2.aruco.generateImageMarker(dictionary, tag_id, side)
    pad = TAG_QUIET_CELLS * TAG_TEXTURE_PIXELS
    printed = cv2.copyMakeBorder(marker, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
    edge = layout.size * (cells + 2 * TAG_QUIET_CELLS) / cells
    return cv2.cvtColor(printed, cv2.COLOR_GRAY2RGB), edge


def _png(image: np.ndarray) -> bytes:
    ok, data = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    assert ok
    return data.tobytes()


def build_scene_xml(base_mjcf: str, layout: MarkerLayout, camera: CameraConfig,
                    hands: bool = False) -> tuple[str, dict[str, bytes]]:
    """The extended MJCF text and its in-memory assets (tag textures); hands: a player's hand (foos_sim.camera.hands)."""
    root = ET.fromstring(base_mjcf)
    visual = root.find("visual")
    glob = visual.find("global")
    glob.set("offwidth", str(max(int(glob.get("offwidth", 640)), camera.width)))
    glob.set("offheight", str(max(int(glob.get("offheight", 480)), camera.height)))
    asset = root.find("asset")
    world = root.find("worldbody")
    assets: dict[str, bytes] = {}
    ET.SubElement(asset, "material", name="vision_floor", rgba="0.22 0.22 0.24 1")
    ET.SubElement(asset, "material", name="vision_frame", rgba="0.30 0.22 0.15 1")
    # A room floor below the table, so the background is not the skybox.
    ET.SubElement(world, "geom", name="vision_floor", type="plane", size="4 4 0.1", pos="0 0 -0.75",
                  material="vision_floor", contype="0", conaffinity="0")
    for tag_id, position in layout.positions.items():
        image, edge = tag_texture(layout, tag_id)
        file_name = f"vision_tag{tag_id}.png"
        assets[file_name] = _png(image)
        ET.SubElement(asset, "texture", name=f"vision_tag{tag_id}", type="2d", file=file_name)
        ET.SubElement(asset, "material", name=f"vision_tag{tag_id}", texture=f"vision_tag{tag_id}",
                      texrepeat="1 1", texuniform="false", rgba="1 1 1 1", specular="0", shininess="0")
        x, y, z = (float(v) for v in position)
        # The tag lies on a small plate of the table frame; its printed face is exactly at height z.
        ET.SubElement(world, "geom", name=f"vision_tag{tag_id}", type="plane", size=_fmt(edge / 2, edge / 2, 0.01),
                      pos=_fmt(x, y, z + 1e-5), material=f"vision_tag{tag_id}", contype="0", conaffinity="0")
        ET.SubElement(world, "geom", name=f"vision_plate{tag_id}", type="box",
                      size=_fmt(edge / 2 + 0.015, edge / 2 + 0.015, (z + 0.75) / 2),
                      pos=_fmt(x, y, (z - 0.75) / 2 - 1e-4), material="vision_frame", contype="0", conaffinity="0")
    if hands:
        add_hand(world, asset)
    axes = camera.axes()
    ET.SubElement(world, "camera", name=CAMERA_NAME, pos=_fmt(*camera.position),
                  xyaxes=_fmt(*axes[0], *axes[1]), fovy=_fmt(camera.fovy))
    return ET.tostring(root, encoding="unicode"), assets


def build_scene_model(base_mjcf: str, layout: MarkerLayout, camera: CameraConfig, hands: bool = False) -> mujoco.MjModel:
    xml, assets = build_scene_xml(base_mjcf, layout, camera, hands)
    return mujoco.MjModel.from_xml_string(xml, assets)


def set_ball_colour(model: mujoco.MjModel, rgb: tuple[float, float, float]) -> None:
    model.mat_rgba[model.material("ball").id, :3] = rgb


def set_team_colour(model: mujoco.MjModel, team: str, rgb: tuple[float, float, float]) -> None:
    """Real tables come with other figure colours; a team of the ball's colour is the hard case for a tracker."""
    model.mat_rgba[model.material(team).id, :3] = rgb


def hide_cover(model: mujoco.MjModel) -> None:
    """The clear cover renders as a tinted sheet; a real camera sees through a clean one."""
    model.geom_rgba[model.geom("cover").id, 3] = 0.0


def set_rod_finish(model: mujoco.MjModel, grey: float = 0.45) -> None:
    """Brushed-steel rods: foos_sim's light grey renders near white under the table lights."""
    model.mat_rgba[model.material("rod").id, :3] = (grey, grey, grey * 1.03)
    model.mat_specular[model.material("rod").id] = 0.3


def set_lighting(model: mujoco.MjModel, scale: float, ambient: float = 0.15) -> None:
    model.light_diffuse[:] = np.clip(model.light_diffuse * scale, 0, 1)
    model.vis.headlight.ambient[:] = ambient
    model.vis.headlight.diffuse[:] = 0.25 * scale


BALL_COLOURS = {
    "white": (0.95, 0.95, 0.92),
    "yellow": (0.95, 0.80, 0.10),
    "orange": (0.98, 0.45, 0.05),
    "red": (0.85, 0.08, 0.08),
}
# What --home-color and --away-color take by name, besides the ball colours.
FIGURE_COLOURS = {**BALL_COLOURS, "blue": (0.10, 0.20, 0.80), "black": (0.08, 0.08, 0.08)}
