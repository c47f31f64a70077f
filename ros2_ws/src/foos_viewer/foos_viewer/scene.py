"""The table as Foxglove 3D scene entities, in the contract's `table` frame. No ROS here.

Every shape comes from the one MuJoCo model of the table (`foos_sim.load_model(params_file)`), so the
viewer shows what the simulation simulates: the field, walls and goal pockets (the world body's geoms),
the 8 rods with their figures (each rod body's geoms, posed by MuJoCo's own kinematics from the 16 joint
positions) and the ball's size and colour.

    scene = TableScene(params_file)
    scene.table_entity(now_ns)                       # static
    scene.rod_entities(joint_positions, now_ns)      # 16 values in JOINT_NAMES order
    scene.ball_entity(position, velocity, stamp, now_ns)
    scene.detections_entity(trail, stamp, now_ns)
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import mujoco
import numpy as np
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    CylinderPrimitive,
    KeyValuePair,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SpherePrimitive,
    Timestamp,
    Vector3,
)

from foos_core.names import BALL_BODY, JOINT_NAMES, RODS, TABLE_FRAME, TEAMS, rod_name
from foos_sim import load_model

# Entity ids on the scene topics; a later entity with the same id replaces the earlier one.
TABLE_ID = "table"
BALL_ID = "ball"
DETECTIONS_ID = "detections"


def rod_entity_id(team: str, rod: str) -> str:
    return f"rod/{rod_name(team, rod)}"


# The measured ball's colour: it must stand apart from the white simulated/filtered ball and both teams.
DETECTION_COLOR = Color(r=1.0, g=0.75, b=0.0, a=1.0)
VELOCITY_ARROW_SECONDS = 0.1  # the ball's velocity arrow reaches where the ball will be this much later
TRAIL_WIDTH = 0.004  # m
MUJOCO_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)  # a geom's rgba when its colour comes from its material


def timestamp(ns: int) -> Timestamp:
    return Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def stamp_text(sec: int, nanosec: int) -> str:
    """A ROS stamp written exactly, so a client can match an entity to the message it came from."""
    return f"{sec}.{nanosec:09d}"


def _vector(values) -> Vector3:
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def _pose(position, quaternion_wxyz=(1.0, 0.0, 0.0, 0.0)) -> Pose:
    w, x, y, z = (float(v) for v in quaternion_wxyz)
    return Pose(position=_vector(position), orientation=Quaternion(x=x, y=y, z=z, w=w))


def _color(rgba) -> Color:
    r, g, b, a = (float(v) for v in rgba)
    return Color(r=r, g=g, b=b, a=a)


def _heading_quaternion(direction) -> tuple[float, float, float, float]:
    """The rotation (w, x, y, z) that turns +x (an arrow's axis) toward `direction`: yaw, then pitch."""
    dx, dy, dz = (float(v) for v in direction)
    yaw, pitch = math.atan2(dy, dx), -math.atan2(dz, math.hypot(dx, dy))
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return (cy * cp, -sy * sp, cy * sp, sy * cp)


def geom_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """A geom's colour as MuJoCo draws it: its own rgba, else its material's, a texture's mean colour included."""
    rgba = np.array(model.geom_rgba[geom], dtype=float)
    material = int(model.geom_matid[geom])
    if material < 0 or not np.allclose(rgba, MUJOCO_DEFAULT_RGBA):
        return rgba
    rgba = np.array(model.mat_rgba[material], dtype=float)
    textures = [int(t) for t in np.atleast_1d(model.mat_texid[material]) if t >= 0]
    if textures:
        texture = textures[0]
        channels = int(model.tex_nchannel[texture])
        size = int(model.tex_height[texture]) * int(model.tex_width[texture]) * channels
        texels = model.tex_data[model.tex_adr[texture]:model.tex_adr[texture] + size].reshape(-1, channels)
        rgba[:3] *= texels[:, :3].mean(axis=0) / 255.0
    return rgba


class TableScene:
    """One table's scene: its static part once, the rods posed from joint positions, ball and detections."""

    def __init__(self, params_file: str | Path | None = None):
        self.model = load_model(params_file)  # foos_core.table_params.ParamsError for a bad file
        self.data = mujoco.MjData(self.model)
        self._joint_qpos = np.array([self.model.joint(name).qposadr[0] for name in JOINT_NAMES])
        body_of_rod = {(team, rod): self.model.body(rod_name(team, rod)).id for team in TEAMS for rod in RODS}
        geoms_of_body: dict[int, list[int]] = {}
        for geom in range(self.model.ngeom):
            geoms_of_body.setdefault(int(self.model.geom_bodyid[geom]), []).append(geom)
        self.rod_geoms = {key: geoms_of_body[body] for key, body in body_of_rod.items()}
        # The see-through cover is left out, so the table is seen from above as on a camera.
        self.table_geoms = [g for g in geoms_of_body[0] if geom_rgba(self.model, g)[3] >= 1.0]
        ball_geom = geoms_of_body[self.model.body(BALL_BODY).id][0]
        self.ball_diameter = 2.0 * float(self.model.geom_size[ball_geom][0])
        self.ball_color = _color(geom_rgba(self.model, ball_geom))
        self._shapes = {geom: self._shape(geom) for geom in self.table_geoms + sum(self.rod_geoms.values(), [])}
        self.joint_positions = np.zeros(len(JOINT_NAMES))
        self._pose_rods(self.joint_positions)

    # --- shapes from the model -------------------------------------------------------------------
    def _pose_rods(self, joint_positions: np.ndarray) -> None:
        self.data.qpos[self._joint_qpos] = joint_positions
        mujoco.mj_kinematics(self.model, self.data)

    def _geom_pose(self, geom: int) -> Pose:
        quaternion = np.zeros(4)
        mujoco.mju_mat2Quat(quaternion, self.data.geom_xmat[geom])
        return _pose(self.data.geom_xpos[geom], quaternion)

    def _shape(self, geom: int) -> tuple[str, Vector3, Color, Pose | None]:
        """What stays of a geom while it moves: its kind of primitive, size and colour (and its pose, when a
        dented field is drawn flat in place of its height field)."""
        kind, size = int(self.model.geom_type[geom]), self.model.geom_size[geom]
        color = _color(geom_rgba(self.model, geom))
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            return "cubes", _vector(2 * size), color, None
        if kind == mujoco.mjtGeom.mjGEOM_HFIELD:
            # A dented field: drawn flat at the field's extent; its millimetre dents would not show.
            half_x, half_y, _, base = (float(v) for v in self.model.hfield_size[int(self.model.geom_dataid[geom])])
            return "cubes", Vector3(x=2 * half_x, y=2 * half_y, z=base), color, _pose((0.0, 0.0, -base / 2))
        if kind in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER):
            # MuJoCo's geom frame has z along the axis, as a Foxglove cylinder has; size[1] is the half-length.
            diameter = 2 * float(size[0])
            return "cylinders", Vector3(x=diameter, y=diameter, z=2 * float(size[1])), color, None
        if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            d = 2 * float(size[0])
            return "spheres", Vector3(x=d, y=d, z=d), color, None
        raise ValueError(f"the viewer cannot draw geom `{self.model.geom(geom).name}` of MuJoCo type {kind}")

    def _primitives(self, geoms: Sequence[int]) -> dict[str, list]:
        """The geoms as Foxglove primitives at their current poses, in the model's geom order within each kind."""
        out: dict[str, list] = {"cubes": [], "cylinders": [], "spheres": []}
        for geom in geoms:
            kind, size, color, fixed_pose = self._shapes[geom]
            pose = fixed_pose if fixed_pose is not None else self._geom_pose(geom)
            if kind == "cubes":
                out[kind].append(CubePrimitive(pose=pose, size=size, color=color))
            elif kind == "cylinders":
                out[kind].append(CylinderPrimitive(pose=pose, size=size, bottom_scale=1.0, top_scale=1.0, color=color))
            else:
                out[kind].append(SpherePrimitive(pose=pose, size=size, color=color))
        return out

    # --- entities --------------------------------------------------------------------------------
    def table_entity(self, now_ns: int) -> SceneEntity:
        return SceneEntity(timestamp=timestamp(now_ns), frame_id=TABLE_FRAME, id=TABLE_ID,
                           **self._primitives(self.table_geoms))

    def rod_entities(self, joint_positions: Sequence[float], now_ns: int, stamp: str = "") -> list[SceneEntity]:
        """One entity per rod: its rod and its figures' body and foot boxes (figure order, body then foot),
        posed from the 16 joint positions (JOINT_NAMES order; a NaN keeps that joint where it was)."""
        positions = np.asarray(joint_positions, dtype=float)
        self.joint_positions = np.where(np.isnan(positions), self.joint_positions, positions)
        self._pose_rods(self.joint_positions)
        entities = []
        for (team, rod), geoms in self.rod_geoms.items():
            slide, rotate = (self.joint_positions[JOINT_NAMES.index(f"{rod_name(team, rod)}_{axis}")] for axis in ("slide", "rotate"))
            metadata = [KeyValuePair(key="slide", value=f"{slide:.6f}"), KeyValuePair(key="rotate", value=f"{rotate:.6f}"),
                        KeyValuePair(key="stamp", value=stamp)]
            entities.append(SceneEntity(timestamp=timestamp(now_ns), frame_id=TABLE_FRAME, id=rod_entity_id(team, rod),
                                        metadata=metadata, **self._primitives(geoms)))
        return entities

    def ball_entity(self, position: Sequence[float], velocity: Sequence[float], stamp: str, now_ns: int) -> SceneEntity:
        """The ball of /ball/state (sim_node's simulated ball, or a tracker's filtered estimate), with an arrow
        to where its velocity takes it in VELOCITY_ARROW_SECONDS."""
        d = self.ball_diameter
        sphere = SpherePrimitive(pose=_pose(position), size=Vector3(x=d, y=d, z=d), color=self.ball_color)
        arrows = []
        speed = float(np.linalg.norm(velocity))
        if speed * VELOCITY_ARROW_SECONDS > d / 2:
            length = speed * VELOCITY_ARROW_SECONDS
            arrows.append(ArrowPrimitive(pose=_pose(position, _heading_quaternion(velocity)), shaft_length=0.8 * length,
                                         shaft_diameter=d / 5, head_length=0.2 * length, head_diameter=d / 2,
                                         color=self.ball_color))
        return SceneEntity(timestamp=timestamp(now_ns), frame_id=TABLE_FRAME, id=BALL_ID, spheres=[sphere], arrows=arrows,
                           metadata=[KeyValuePair(key="stamp", value=stamp), KeyValuePair(key="speed", value=f"{speed:.4f}")])

    def detections_entity(self, trail: Sequence[Sequence[float]], stamp: str, now_ns: int) -> SceneEntity:
        """The latest /ball/detection as a ball in DETECTION_COLOR, and the trail of those before it as a line."""
        d = self.ball_diameter
        spheres = [SpherePrimitive(pose=_pose(trail[-1]), size=Vector3(x=d, y=d, z=d), color=DETECTION_COLOR)] if trail else []
        lines = []
        if len(trail) > 1:
            points = [Point3(x=float(p[0]), y=float(p[1]), z=float(p[2])) for p in trail]
            lines.append(LinePrimitive(type=LinePrimitiveLineType.LineStrip, pose=_pose((0.0, 0.0, 0.0)), thickness=TRAIL_WIDTH,
                                       scale_invariant=False, points=points, color=DETECTION_COLOR))
        return SceneEntity(timestamp=timestamp(now_ns), frame_id=TABLE_FRAME, id=DETECTIONS_ID, spheres=spheres, lines=lines,
                           metadata=[KeyValuePair(key="stamp", value=stamp), KeyValuePair(key="points", value=str(len(trail)))])
