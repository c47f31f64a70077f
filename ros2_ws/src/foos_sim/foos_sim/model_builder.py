"""MJCF of the table, generated from a parameter tree (foos_core.table_params: foos_core/params/*.yaml).

Every ball contact is an explicit <pair>, so each has exactly the friction, condim and spring the
parameter file asks for; nothing else in the model collides (rods are driven, figures of different
rods pass each other as on a real table, and the ball is the only free body).

Two physics, chosen by `solver.physics` in the parameter file (PHYSICS):
- `reference`: the ball's wall and figure contacts are linear springs whose damping gives the
  restitution, at 20 kHz (`solver.timestep`). Its mj_step alone is the table's whole physics.
- `fast`: `solver.fast.timestep` (0.5-2 ms); the wall and figure contacts are stiff and nearly
  inelastic, with a gap that sees impacts one step ahead, and foos_sim.impacts resolves each impact
  exactly (TableSimulation runs it). Stepped by mj_step alone, its walls and figures would not bounce.
"""
from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from foos_core.names import (
    AXES,
    BALL_BODY,
    BALL_JOINT,
    FIELD_GEOM,
    JOINT_NAMES,
    RODS,
    TEAMS,
    figure_team,
    joint_name,
)
from foos_core.table_params import load_params

from . import effects as effects_mod
from .impacts import ImpactSurface

# Solver impedance held constant over penetration, so each ball contact is a linear spring-damper and
# its restitution does not depend on impact speed.
BALL_SOLIMP = "0.99 0.99 0.001 0.5 2"
# The fast physics' contacts hold harder once pressed in: a figure pressing the ball into the field or a
# wall (up to 130 N) sinks it by (1 - d) / d times its push over the contact's stiffness.
FAST_BALL_SOLIMP = "0.999 0.9999 0.001 0.5 2"
HFIELD_CELL = 0.004  # m, height-field resolution of a dented surface
PHYSICS = ("fast", "reference")
DEFAULT_PHYSICS = "reference"  # of a parameter file that names none (files written before the fast physics)
# Initial look-ahead gap of the fast model's impact pairs; TableSimulation sets it from the ball's speed.
INITIAL_IMPACT_GAP = 0.02
# m/s: a ball landing slower than this settles in the field contact (a resting ball gains g h per step).
FIELD_MIN_IMPACT_SPEED = 0.1


class PhysicsError(ValueError):
    """A parameter file whose `solver.physics` (or fast settings) cannot be run."""


def physics_name(params: dict, override: str | None = None) -> str:
    """Which physics a table runs: `override` when given, else the parameter file's `solver.physics`."""
    name = override if override is not None else params["solver"].get("physics", DEFAULT_PHYSICS)
    if name not in PHYSICS:
        raise PhysicsError(f"solver.physics must be one of {', '.join(PHYSICS)}, got {name!r}")
    if name == "fast":
        fast = params["solver"].get("fast")
        if not isinstance(fast, dict) or not isinstance(fast.get("timestep"), (int, float)) or not fast["timestep"] > 0:
            raise PhysicsError("the fast physics needs solver.fast.timestep, a positive number of seconds")
    return name


def solver_settings(params: dict, physics: str) -> dict:
    """The solver options of one physics: `solver`, with `solver.fast` on top for the fast one."""
    solver = {k: v for k, v in params["solver"].items() if k not in ("physics", "fast")}
    if physics == "fast":
        solver.update(params["solver"]["fast"])
    return solver


def damping_ratio_for_restitution(restitution: float) -> float:
    """Damping ratio of a continuous linear spring-damper whose bounce returns `restitution`."""
    log_e = math.log(restitution)
    return -log_e / math.sqrt(math.pi**2 + log_e**2)


# Contact onsets fall anywhere within a step; bounces are averaged over these fractions of a step.
_ONSET_PHASES = np.linspace(0.05, 0.95, 7)


def _bounce_model(frequency: float, timestep: float) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(f"""
<mujoco>
  <option timestep="{timestep!r}" gravity="0 0 0" integrator="implicitfast" cone="elliptic"/>
  <worldbody>
    <geom name="wall" type="box" size="0.05 0.1 0.1" pos="0.05 0 0" contype="0" conaffinity="0"/>
    <body name="ball"><joint name="x" type="slide" axis="1 0 0"/>
      <geom name="ball" type="sphere" size="0.02" mass="0.02" contype="0" conaffinity="0"/></body>
  </worldbody>
  <contact><pair geom1="ball" geom2="wall" condim="1" solref="{_fmt(-frequency**2, -frequency)}" solimp="{BALL_SOLIMP}"/></contact>
</mujoco>""")


def _mean_discrete_restitution(model: mujoco.MjModel, damping_ratio: float, frequency: float) -> float:
    model.pair_solref[0] = (-frequency**2, -2.0 * damping_ratio * frequency)
    data = mujoco.MjData(model)
    speed, h = 1.0, model.opt.timestep
    ratios = []
    for phase in _ONSET_PHASES:
        mujoco.mj_resetData(model, data)
        data.qpos[0] = -0.02 - phase * speed * h
        data.qvel[0] = speed
        in_contact = False
        for _ in range(int(50.0 / (frequency * h)) + 10):
            mujoco.mj_step(model, data)
            touching = data.qpos[0] > -0.02
            in_contact |= touching
            if in_contact and not touching:
                break
        ratios.append(-data.qvel[0] / speed)
    return float(np.mean(ratios))


@functools.lru_cache(maxsize=128)
def discrete_damping_ratio(restitution: float, frequency: float, timestep: float) -> float:
    """Damping ratio whose bounce, as MuJoCo integrates it at this timestep, returns `restitution`.

    The continuous formula is off by up to 0.07 at frequency * timestep = 0.3 (contact onset falls
    between steps and damping acts explicitly), so the ratio is found by bisection on a one-ball
    model with the same solver settings, averaging over where in a step the contact begins.
    """
    model = _bounce_model(frequency, timestep)
    low, high = 0.0, 2.0  # restitution falls as damping rises
    for _ in range(30):
        middle = 0.5 * (low + high)
        if _mean_discrete_restitution(model, middle, frequency) > restitution:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def drive_speed_limit(params: dict, axis: str) -> float:
    """The most a slide (m/s) or rotate (rad/s) drive is commanded: its actuator's ctrlrange."""
    return float(params["rods"][f"{axis}_speed_limit"])


def command_limits(params: dict) -> np.ndarray:
    """One team's 8 drive limits in command order, read from the parameters without building a model
    (a controller needs them; TableSimulation.command_limits reads the same off the built actuators)."""
    return np.array([drive_speed_limit(params, axis) for _rod in RODS for axis in AXES])


def _fmt(*values: float) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def _sub(parent: ET.Element, tag: str, **attributes) -> ET.Element:
    return ET.SubElement(parent, tag, {k: str(v) for k, v in attributes.items()})


class TableModelBuilder:
    """Builds the MJCF of one table from its parameter tree."""

    def __init__(self, params: dict, ball_only: bool = False, physics: str | None = None):
        self.params = params
        # ball_only: the same table without rods and figures, for fast rollouts of a free ball. Its users
        # step it with mj_step or mujoco.rollout alone, so it is the reference physics unless asked.
        self.ball_only = ball_only
        self.physics_name = physics_name(params, physics if physics is not None or not ball_only else "reference")
        self.physics = effects_mod.resolve(params)
        self.frequency = float(params["contact"]["natural_frequency"])
        self.solver = solver_settings(params, self.physics_name)
        self.timestep = float(self.solver["timestep"])
        self.ball_contact_geoms: list[tuple[str, str]] = []  # (geom, kind) pairs with the ball
        self.impact_surfaces: dict[str, ImpactSurface] = {}  # the fast physics' walls and figures, after build()

    @property
    def fast(self) -> bool:
        return self.physics_name == "fast"

    @property
    def dented_field(self) -> bool:
        """Whether the field is a height field with the dents. The fast physics keeps it flat and pushes
        the ball down the dents' slopes instead (foos_sim.effects.DentSlopes): a height field's cell edges
        cost a ball rolling across at 2 ms steps speed the reference keeps (10 mm behind it after 0.6 s
        across a 2 mm dent, against 1 mm that the dent itself changes)."""
        return bool(self.physics.dents) and not self.fast

    @property
    def solimp(self) -> str:
        return FAST_BALL_SOLIMP if self.fast else BALL_SOLIMP

    def solref(self, restitution: float | None = None, damping_ratio: float | None = None) -> str:
        if self.fast:
            # Stiff and nearly inelastic (MuJoCo's stiffest stable contact, time constant 2 steps): a bounce
            # comes from foos_sim.impacts, the contact only holds what rests or pushes.
            return _fmt(2.0 * self.timestep, 1.0)
        if damping_ratio is None:
            damping_ratio = discrete_damping_ratio(float(restitution), self.frequency, self.timestep)
        return _fmt(-self.frequency**2, -2.0 * damping_ratio * self.frequency)

    def field_solref(self) -> str:
        if self.fast:
            return _fmt(2.0 * self.timestep, self.params["contact"]["field_damping_ratio"])
        return self.solref(damping_ratio=self.params["contact"]["field_damping_ratio"])

    def friction_share(self, restitution: float) -> float:
        """The share of the slip the reference's friction stops in one impact: its friction acts through the
        spring's damping (2 zeta omega) for the contact's half period (pi / omega)."""
        zeta = discrete_damping_ratio(float(restitution), self.frequency, float(self.params["solver"]["timestep"]))
        return 1.0 - math.exp(-2.0 * math.pi * zeta)

    def reference_contact_duration(self) -> float:
        """s, how long a ball contact lasts on the reference: half a period of its spring."""
        return math.pi / self.frequency

    def figure_reach(self) -> float:
        """m, the farthest a figure's surface is from its rod's axis (a foot's lower edge)."""
        fig, rods = self.params["figure"], self.params["rods"]
        return max(math.hypot(rods["axis_height"] - fig["foot_clearance"], fig["foot_size"][1] / 2), fig["head_height"])

    def figure_speed_limit(self) -> float:
        """m/s, the fastest a figure's surface moves: full slide and rotation speed at the farthest point."""
        p = self.params
        return math.hypot(drive_speed_limit(p, "slide"), drive_speed_limit(p, "rotate") * self.figure_reach())

    def build(self) -> str:
        p = self.params
        solver = self.solver
        root = ET.Element("mujoco", model="foosball_table")
        _sub(root, "compiler", angle="radian", autolimits="true")
        option = _sub(
            root, "option",
            timestep=solver["timestep"], integrator=solver.get("integrator", "implicitfast"),
            cone=solver.get("cone", "elliptic"), iterations=solver.get("iterations", 50),
            tolerance=solver.get("tolerance", 1e-10), noslip_iterations=solver.get("noslip_iterations", 4),
            noslip_tolerance=solver.get("noslip_tolerance", 1e-8), gravity=_fmt(*self.physics.gravity),
            density=_fmt(self.physics.air_density), viscosity=_fmt(self.physics.viscosity),
        )
        del option
        _sub(root, "size", memory="8M")
        visual = _sub(root, "visual")
        _sub(visual, "global", offwidth=1920, offheight=1080)
        _sub(visual, "quality", shadowsize=2048)
        self._assets(root)
        world = _sub(root, "worldbody")
        _sub(world, "light", name="overhead", pos="0 0 2.5", dir="0 0 -1", diffuse="0.8 0.8 0.8", castshadow="false")
        _sub(world, "light", name="fill", pos="0.8 -1.2 2.0", dir="-0.3 0.5 -1", diffuse="0.3 0.3 0.3")
        self._field(world)
        self._walls(world)
        self._ball(world)
        if not self.ball_only:
            actuators = _sub(root, "actuator")
            for rod_name, rod in p["rods"]["layout"].items():
                self._rod(world, actuators, rod_name, rod)
        self._contacts(root)
        ET.indent(root)
        return ET.tostring(root, encoding="unicode")

    def _assets(self, root: ET.Element) -> None:
        asset = _sub(root, "asset")
        _sub(asset, "texture", name="felt", type="2d", builtin="flat", rgb1="0.10 0.45 0.18", width=64, height=64)
        _sub(asset, "material", name="felt", texture="felt", rgba="1 1 1 1")
        _sub(asset, "material", name="wall", rgba="0.55 0.40 0.25 1")
        _sub(asset, "material", name="home", rgba="0.80 0.10 0.10 1")
        _sub(asset, "material", name="away", rgba="0.10 0.20 0.80 1")
        _sub(asset, "material", name="rod", rgba="0.75 0.75 0.78 1")
        _sub(asset, "material", name="ball", rgba="0.95 0.95 0.92 1")
        if self.dented_field:
            self._dented_field_asset(asset)

    def _dented_field_asset(self, asset: ET.Element) -> None:
        f = self.params["field"]
        half_x, half_y = f["width"] / 2, f["length"] / 2
        ncol = int(round(f["width"] / HFIELD_CELL)) + 1
        nrow = int(round(f["length"] / HFIELD_CELL)) + 1
        x = np.linspace(-half_x, half_x, ncol)
        y = np.linspace(-half_y, half_y, nrow)
        xx, yy = np.meshgrid(x, y)
        height = np.zeros_like(xx)
        for dent in self.physics.dents:
            height += dent.height(np.hypot(xx - dent.x, yy - dent.y))
        low, high = float(height.min()), float(height.max())
        span = max(high - low, 1e-6)
        self._hfield_offset = low
        # MuJoCo lays the elevation rows out from +y down to -y (image order): flip our -y-first grid.
        elevation = ((height - low) / span)[::-1]
        _sub(
            asset, "hfield", name="field", nrow=nrow, ncol=ncol,
            size=_fmt(half_x, half_y, span, f["thickness"]),
            elevation=" ".join(f"{v:.5f}" for v in elevation.ravel()),
        )

    def _field(self, world: ET.Element) -> None:
        f = self.params["field"]
        half_x, half_y, t = f["width"] / 2, f["length"] / 2, f["thickness"]
        if self.dented_field:
            # The height field's zero elevation sits at its geom origin; lift it so that undisturbed
            # surface stays at z = 0.
            _sub(world, "geom", name=FIELD_GEOM, type="hfield", hfield="field", pos=_fmt(0, 0, self._hfield_offset),
                 material="felt", contype=0, conaffinity=0)
        else:
            _sub(world, "geom", name=FIELD_GEOM, type="box", size=_fmt(half_x, half_y, t / 2), pos=_fmt(0, 0, -t / 2),
                 material="felt", contype=0, conaffinity=0)
        self.ball_contact_geoms.append((FIELD_GEOM, "field"))
        gw, depth = f["goal_width"] / 2, f["goal_depth"]
        for team, sign in (("home", -1.0), ("away", 1.0)):
            name = f"goal_{team}_floor"
            _sub(world, "geom", name=name, type="box", size=_fmt(gw, depth / 2, t / 2),
                 pos=_fmt(0, sign * (half_y + depth / 2), -t / 2), material="felt", contype=0, conaffinity=0)
            self.ball_contact_geoms.append((name, "field"))

    def _wall(self, world: ET.Element, name: str, center, half_size) -> None:
        _sub(world, "geom", name=name, type="box", size=_fmt(*half_size), pos=_fmt(*center), material="wall",
             contype=0, conaffinity=0, rgba="0.55 0.40 0.25 0.35" if "cover" in name else "0.55 0.40 0.25 1")
        self.ball_contact_geoms.append((name, "wall"))

    def _walls(self, world: ET.Element) -> None:
        f = self.params["field"]
        half_x, half_y = f["width"] / 2, f["length"] / 2
        h, t, gw = f["wall_height"], f["wall_thickness"], f["goal_width"] / 2
        gh, depth = f["goal_height"], f["goal_depth"]
        outer_y = half_y + depth + t
        for side, sign in (("neg_x", -1.0), ("pos_x", 1.0)):
            self._wall(world, f"wall_side_{side}", (sign * (half_x + t / 2), 0, h / 2), (t / 2, outer_y, h / 2))
        segment = (half_x - gw) / 2
        for team, sign in (("home", -1.0), ("away", 1.0)):
            y_wall = sign * (half_y + t / 2)
            for side, sx in (("neg_x", -1.0), ("pos_x", 1.0)):
                self._wall(world, f"wall_end_{team}_{side}", (sx * (gw + segment), y_wall, h / 2), (segment, t / 2, h / 2))
            self._wall(world, f"wall_end_{team}_lintel", (0, y_wall, (gh + h) / 2), (gw, t / 2, (h - gh) / 2))
            # The goal pocket behind the mouth: it keeps a scored ball, as a real goal box does.
            y_pocket = sign * (half_y + depth / 2)
            for side, sx in (("neg_x", -1.0), ("pos_x", 1.0)):
                self._wall(world, f"wall_goal_{team}_{side}", (sx * (gw + t / 2), y_pocket, gh / 2), (t / 2, depth / 2, gh / 2))
            self._wall(world, f"wall_goal_{team}_back", (0, sign * (half_y + depth + t / 2), gh / 2), (gw + t, t / 2, gh / 2))
            self._wall(world, f"wall_goal_{team}_roof", (0, y_pocket, gh + t / 2), (gw + t, depth / 2 + t / 2, t / 2))
        ch = f["cover_height"]
        self._wall(world, "cover", (0, 0, ch + t / 2), (half_x + t, outer_y, t / 2))

    def _ball(self, world: ET.Element) -> None:
        b = self.params["ball"]
        body = _sub(world, "body", name=BALL_BODY, pos=_fmt(0, 0, b["radius"]))
        _sub(body, "freejoint", name=BALL_JOINT)
        geom = _sub(body, "geom", name="ball", type="sphere", size=_fmt(b["radius"]), mass=_fmt(b["mass"]),
                    material="ball", contype=0, conaffinity=0)
        if self.physics.air_density > 0 or self.physics.viscosity > 0:
            # Ellipsoid fluid model with only the blunt drag term, so drag is |v| v (no lift, no Magnus).
            geom.set("fluidshape", "ellipsoid")
            geom.set("fluidcoef", _fmt(self.physics.ball_blunt_drag, 0, 0, 0, 0))

    def _rod(self, world: ET.Element, actuators: ET.Element, rod_name: str, rod: dict) -> None:
        p = self.params
        r, fig, f = p["rods"], p["figure"], p["field"]
        team, role = rod_name.split("_", 1)
        if team not in TEAMS or role not in RODS:
            raise ValueError(f"rod `{rod_name}` is not <team>_<rod> with the contract's names")
        body = _sub(world, "body", name=rod_name, pos=_fmt(0, rod["y"], r["axis_height"]))
        slide, rotate = (joint_name(team, role, axis) for axis in AXES)
        _sub(body, "joint", name=slide, type="slide", axis="1 0 0", range=_fmt(-rod["travel"], rod["travel"]),
             armature=_fmt(r["slide_armature"]))
        _sub(body, "joint", name=rotate, type="hinge", axis="1 0 0", armature=_fmt(r["rotate_armature"]))
        length = f["width"] + 2 * f["wall_thickness"] + 0.3
        _sub(body, "geom", name=f"{rod_name}_rod", type="capsule", fromto=_fmt(-length / 2, 0, 0, length / 2, 0, 0),
             size=_fmt(r["radius"]), mass=_fmt(r["mass"]), material="rod", contype=0, conaffinity=0)
        foot_x, foot_y, foot_z = fig["foot_size"]
        body_x, body_y = fig["body_size"]
        foot_bottom = -(r["axis_height"] - fig["foot_clearance"])
        foot_top = foot_bottom + foot_z
        # Body mass is most of the figure; the foot is the striking block.
        body_mass, foot_mass = 0.7 * fig["mass"], 0.3 * fig["mass"]
        n = int(rod["figures"])
        for i in range(n):
            x = (i - (n - 1) / 2) * rod["spacing"]
            name = f"{rod_name}_figure{i}"
            _sub(body, "geom", name=f"{name}_body", type="box", size=_fmt(body_x / 2, body_y / 2, (fig["head_height"] - foot_top) / 2),
                 pos=_fmt(x, 0, (fig["head_height"] + foot_top) / 2), mass=_fmt(body_mass), material=team,
                 contype=0, conaffinity=0)
            _sub(body, "geom", name=f"{name}_foot", type="box", size=_fmt(foot_x / 2, foot_y / 2, foot_z / 2),
                 pos=_fmt(x, 0, (foot_top + foot_bottom) / 2), mass=_fmt(foot_mass), material=team,
                 contype=0, conaffinity=0)
            self.ball_contact_geoms += [(f"{name}_body", "figure"), (f"{name}_foot", "figure")]
        for joint, limit, gain, force in (
            (slide, drive_speed_limit(p, "slide"), r["slide_gain"], r["slide_force_limit"]),
            (rotate, drive_speed_limit(p, "rotate"), r["rotate_gain"], r["rotate_torque_limit"]),
        ):
            _sub(actuators, "velocity", name=joint, joint=joint, kv=_fmt(gain), ctrlrange=_fmt(-limit, limit),
                 forcerange=_fmt(-force, force))

    def _contacts(self, root: ET.Element) -> None:
        p = self.params
        b = p["ball"]
        rolling_friction = effects_mod.ROLLING_MASS_FACTOR * b["radius"] * self.physics.rolling_deceleration / p["gravity"]
        # Buoyancy of a fluid model lightens the contact; restore the rolling resistance it takes away.
        rolling_friction *= effects_mod.buoyancy_factor(self.physics.air_density, b["radius"], b["mass"])
        contact = _sub(root, "contact")
        for geom, kind in self.ball_contact_geoms:
            if kind == "field":
                mu = b["sliding_friction"]
                pair = _sub(contact, "pair", geom1="ball", geom2=geom, condim=6,
                            friction=_fmt(mu, mu, b["spin_friction"], rolling_friction, rolling_friction),
                            solref=self.field_solref(), solimp=self.solimp)
                if self.fast:
                    # A stiff normal with stiff friction lifts a sliding ball: MuJoCo's soft friction cone
                    # trades normal force for friction (a ball launched sliding at 2 m/s hopped 11 mm, 3.8 mm
                    # on the reference). A softer friction reference lifts it less (1.7 mm at 0.01 s), and the
                    # slip still ends when it should (5/7 of the speed after 0.19 s at 2 m/s, within 0.3 %).
                    pair.set("solreffriction", _fmt(float(self.solver["field_friction_timeconst"]), 1.0))
                    # A landing (or a ball a figure presses down) stops dead, as on the reference's critically
                    # damped field. Without a gap: the floor is under the ball anyway, and a dented field's
                    # height field reported its 50 contacts from the cells within the gap, not those holding
                    # the ball (it fell through).
                    self.impact_surfaces[geom] = ImpactSurface(0.0, float(mu), -1, FIELD_MIN_IMPACT_SPEED, floor=True)
            else:
                if kind == "wall":
                    e = self.physics.wall_restitution.get(geom, self.physics.wall_restitution.get("*", p["walls"]["restitution"]))
                    mu, team = float(p["walls"]["friction"]), -1
                else:
                    e = self.physics.figure_restitution
                    e = float(p["figures"]["restitution"]) if e is None else e
                    mu = float(p["figures"]["friction"])
                    team = TEAMS.index(figure_team(geom))
                pair = _sub(contact, "pair", geom1="ball", geom2=geom, condim=3, friction=_fmt(mu, mu, 0, 0, 0),
                            solref=self.solref(restitution=e), solimp=self.solimp)
                if self.fast:
                    self._see_impacts_coming(pair, geom, ImpactSurface(float(e), mu, team, friction_share=self.friction_share(e)))

    def _see_impacts_coming(self, pair: ET.Element, geom: str, surface: ImpactSurface) -> None:
        # MuJoCo 4 reports a contact up to margin + gap apart and pushes only within the margin: with a
        # margin of 0 the impact solver sees contacts coming within the gap.
        pair.set("margin", "0")
        pair.set("gap", _fmt(INITIAL_IMPACT_GAP))
        self.impact_surfaces[geom] = surface


def build_mjcf(params_file: str | Path | None = None, params: dict | None = None, physics: str | None = None) -> str:
    """The MJCF text of a table, from a parameter file (nominal table when None) or a parameter tree, with
    the physics the parameters name (or `physics`). Both have the same bodies, joints, geoms and qpos."""
    return TableModelBuilder(params if params is not None else load_params(params_file), physics=physics).build()


def load_model(params_file: str | Path | None = None, physics: str = "reference") -> mujoco.MjModel:
    """The nominal table (or the one a calibrated parameter file describes) as a MuJoCo model.

    The reference physics by default: its mj_step alone is the whole physics, bounces included, as a
    user stepping the bare model expects. TableSimulation runs the physics the parameter file names.
    """
    return model_from_params(load_params(params_file), physics)


def model_from_params(params: dict, physics: str | None = None) -> mujoco.MjModel:
    return build_model(params, physics)[0]


def build_model(params: dict, physics: str | None = None) -> tuple[mujoco.MjModel, TableModelBuilder]:
    """The table's model and the builder that made it (its physics name, solver, impact surfaces)."""
    builder = TableModelBuilder(params, physics=physics)
    model = mujoco.MjModel.from_xml_string(builder.build())
    _check_actuator_order(model)
    return model, builder


def ball_model_from_params(params: dict) -> mujoco.MjModel:
    """The table without rods: field, walls, effects and the ball (free joint `ball`, qpos[0:7]).

    Calibration rolls thousands of free-ball segments through it; everything the ball touches
    away from the figures is the same as in the full model.
    """
    return mujoco.MjModel.from_xml_string(TableModelBuilder(params, ball_only=True).build())


def _check_actuator_order(model: mujoco.MjModel) -> None:
    names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in range(model.nu))
    if set(names) != set(JOINT_NAMES):
        raise ValueError(f"model actuators {names} are not the contract's 16 rod joints")
