"""Exact ball impacts for the fast physics: restitution and friction as impulses, not as springs.

MuJoCo's soft contacts take several steps, so a spring's bounce depends on the timestep: the 20 kHz
reference springs (foos_sim.model_builder) are unstable at 0.5 ms. The fast model therefore makes the
ball's contacts stiff and nearly inelastic, and resolves every impact here, between mj_step1
(collision) and mj_step2 (forces and integration) of the step in which it happens:

- Each ball-wall and ball-figure pair has a gap (MuJoCo 4 reports a contact up to margin + gap apart
  and applies force only within the margin, here 0) covering one step of the ball's and a figure's
  travel. A contact whose gap the relative normal velocity closes within this step, or that overlaps
  while approaching, is an impact. The floors have none: they are met as the smooth surface the
  parameters describe (ImpactSurface.floor).
- Impulses follow rigid-body impact on the whole system. With the contacts' Jacobians J (ball point
  minus the other body's point) and the mass matrix M, W = J M^-1 J^T couples them. The normal
  impulses are solved together (a linear complementarity problem): each impact's relative normal
  velocity u becomes -e u, no other contact starts approaching, and no impulse pulls. A ball pinched
  between a foot and the field is squeezed out as a rigid ball would be; one impact at a time did not
  converge (the foot and the field took turns, and the rest pressed the ball 8 mm into the field).
  Then each impact's tangential velocity is stopped, within mu times its normal impulse (else it slides)
  and within what the reference's friction stops in its contact's time (ImpactSurface.friction_share).
- A rod takes the reaction through M^-1 J^T, with its drive's armature; its velocity servo resists too,
  as a damper (kv) acting for as long as the reference's contact lasts (pi / natural frequency, 0.5 ms),
  so a figure recoils as on the 20 kHz reference (without it, a figure at rest returned 0.36 of the
  ball's speed where the reference returns 0.41-0.46).
- Position: overlaps are cleared before the forces are computed, by the least move (weighted by mass)
  of the ball and the rods that clears them and closes no other gap: the ball moves out of a figure,
  and where it cannot (pressed onto the field, squeezed against a wall) the rod gives way. Every figure
  overlap is cleared, so MuJoCo's figure contacts never push the ball on through a step with the
  surfaces it could meet not yet among its contacts. A single impact happened t* = gap / |u| into the
  step: the ball is then shifted by (v_before - v_after) t* after the step, to where an instantaneous
  bounce at t* would have it, short of any surface it would reach.
- MuJoCo's stiff contacts keep what is not an impact: a ball resting on the field or against a wall,
  and a squeeze no move can undo.

Impacts slower than an ImpactSurface's min_speed are left to those contacts: on a wall or a figure the
bounce would be under 1 mm/s; on the field, a resting ball gains g h (2 cm/s at 500 Hz) toward the field
in every step, which its contact holds (with the rolling resistance) and an impulse must not.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from foos_core.names import BALL_BODY, FIELD_GEOM, TEAMS

CLEARANCE = 1e-6  # m left between the surfaces after an overlap is projected out
# m left between a figure and the ball: enough that the move, figured on the contact's tangent plane, leaves
# no overlap with a turning foot (its contact would push the ball on through the step, with no wall contact
# yet in MuJoCo's: a ball pushed so went 3 mm into an end wall).
FIGURE_CLEARANCE = 1e-4
TOUCHING = 1e-5  # m of overlap at which a contact the ball is pressed against stays in MuJoCo's contacts
NOT_TOUCHING = (False, False)
GAP_REFRESH_STEPS = 5
FLOOR_SNAP = 0.002  # m: a squeezed ball this close above the floor is set down on it
OVERLAP_TOLERANCE = 2e-4  # m: a wall overlapping the ball by more is cleared; less, its contact holds
ENUMERATED_LCP_SIZE = 6  # up to this many contacts the complementarity problem is solved exactly


@dataclass(frozen=True)
class ImpactSurface:
    """What an impact with one geom does: its restitution and friction, and whose figure it is."""

    restitution: float
    friction: float
    team: int  # index into TEAMS for a figure, -1 for a wall or the field
    min_speed: float = 1e-3  # m/s of approach below which the stiff contact alone takes it
    # A floor (the field, a goal floor) is met as the plane it stands for (ImpactSolver.floor_below), not as
    # MuJoCo's contacts with it: where the field meets a goal floor a ball rolling across sees the field's
    # edge (a 5 m/s roll into the goal hopped 1.3 m/s off the seam).
    floor: bool = False
    # The share of a sticking contact's slip its friction stops in one impact. The reference's friction
    # acts through its spring's damping (2 zeta omega) for the half period (pi / omega) the contact lasts,
    # so it stops at most 1 - exp(-2 pi zeta) of the slip (0.43 on a wall of restitution 0.75, 0.74 on a
    # figure): a ball rolling into a wall at 3 m/s left it rising at 0.23 m/s with the whole slip stopped,
    # 0.11 on the reference.
    friction_share: float = 1.0


def solve_lcp(a: np.ndarray, q: np.ndarray) -> np.ndarray:
    """x >= 0 with w = a x + q >= 0 and x . w = 0, for a symmetric positive semidefinite `a`.

    Small problems (a handful of contacts) are solved exactly by trying the active sets, fewest first, in
    plain Python (numpy's per-call cost dwarfs a 2 x 2 solve); larger ones by projected Gauss-Seidel."""
    n = len(q)
    qs = q.tolist()
    if n == 0 or min(qs) >= 0.0:
        return np.zeros(n)
    rows = a.tolist()
    if n <= ENUMERATED_LCP_SIZE:
        scale = max(1.0, max(abs(v) for v in qs))
        for size in range(1, n + 1):
            for active in itertools.combinations(range(n), size):
                x_active = _solve_small([[rows[i][j] for j in active] for i in active], [-qs[i] for i in active])
                if x_active is None or min(x_active) < -1e-12 * scale:
                    continue
                x = [0.0] * n
                for i, value in zip(active, x_active):
                    x[i] = max(value, 0.0)
                if all(sum(r[j] * x[j] for j in range(n)) + qi >= -1e-9 * scale for r, qi in zip(rows, qs)):
                    return np.array(x)
    x = [0.0] * n
    for _ in range(200):
        for i in range(n):
            x[i] = max(0.0, x[i] - (sum(rows[i][j] * x[j] for j in range(n)) + qs[i]) / max(rows[i][i], 1e-12))
    return np.array(x)


def _solve_small(a: list, b: list) -> list | None:
    """a x = b for a small symmetric positive semidefinite a (lists); least squares when singular (two
    contacts with the same normal: a figure's body and foot); None if that fails."""
    n = len(b)
    if n == 1:
        return [b[0] / a[0][0]] if a[0][0] > 1e-12 else None
    if n == 2:
        det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
        if abs(det) > 1e-12 * max(1.0, a[0][0] * a[1][1]):
            return [(b[0] * a[1][1] - a[0][1] * b[1]) / det, (a[0][0] * b[1] - a[1][0] * b[0]) / det]
    try:
        return np.linalg.lstsq(np.array(a), np.array(b), rcond=None)[0].tolist()
    except np.linalg.LinAlgError:
        return None


class ImpactSolver:
    """Finds and resolves the ball's impacts in one step of the fast model (see the module's docstring)."""

    def __init__(self, model: mujoco.MjModel, surfaces: dict[str, ImpactSurface], figure_speed_limit: float,
                 contact_duration: float, field_half: tuple[float, float], cover_height: float):
        self.model = model
        self.field_half = field_half  # m, the inner faces of the side and end walls (x, y)
        self.cover_height = cover_height
        self.field_geom = model.geom(FIELD_GEOM).id
        self.field_min_speed = surfaces[FIELD_GEOM].min_speed
        self.timestep = float(model.opt.timestep)
        self.ball_body = model.body(BALL_BODY).id
        self.ball_geom = int(model.body_geomadr[self.ball_body])
        self.ball_radius = float(model.geom_size[self.ball_geom][0])
        ball_joint = model.body_jntadr[self.ball_body]
        self.ball_qpos = int(model.jnt_qposadr[ball_joint])
        self.ball_qvel = int(model.jnt_dofadr[ball_joint])
        # Per geom id (plain lists: the per-step screen runs in Python over a handful of contacts).
        self.surface_of: list[ImpactSurface | None] = [None] * model.ngeom
        for name, surface in surfaces.items():
            self.surface_of[model.geom(name).id] = surface
        self.wall_or_figure = [s is not None and not s.floor for s in self.surface_of]
        pair_others = np.where(model.pair_geom1 == self.ball_geom, model.pair_geom2, model.pair_geom1)
        floor_pairs = [s is not None and s.floor for s in (self.surface_of[g] for g in pair_others)]
        if floor_pairs != sorted(floor_pairs, reverse=True):
            raise ValueError("the impact solver needs the ball's floor pairs before its other pairs")
        self.geom_body = [int(b) for b in model.geom_bodyid]
        # A figure geom's rod: its body and the dofs of its slide and its rotation (about +x through the body's
        # origin), from which the screen has a figure point's velocity; None for the world's geoms.
        self.rod_of: list[tuple[int, int, int] | None] = [None] * model.ngeom
        for g, body in enumerate(self.geom_body):
            if body != 0 and body != self.ball_body:
                slide, rotate = (int(model.jnt_dofadr[j]) for j in range(model.body_jntadr[body], model.body_jntadr[body] + 2))
                self.rod_of[g] = (body, slide, rotate)
        # The ball's pairs with walls and with figures: their gap (look-ahead) follows the ball's speed.
        looks_ahead = [s is not None and not s.floor for s in self.surface_of]
        self.wall_pairs = np.array([i for i, g in enumerate(pair_others) if looks_ahead[g] and self.rod_of[g] is None], dtype=int)
        self.figure_pairs = np.array([i for i, g in enumerate(pair_others) if looks_ahead[g] and self.rod_of[g] is not None], dtype=int)
        self.figure_speed_limit = figure_speed_limit
        # Each drive's servo gain (kv) on its joint's dof, times the time it acts during an impact, and the
        # most it can push back in that time (its force limit times the time).
        drive_dofs = model.jnt_dofadr[model.actuator_trnid[:, 0]]
        self.drive_damping = np.zeros(model.nv)
        self.drive_damping[drive_dofs] = model.actuator_gainprm[:, 0] * contact_duration
        self.drive_impulse_limit = np.full(model.nv, np.inf)
        self.drive_impulse_limit[drive_dofs] = model.actuator_forcerange[:, 1] * contact_duration
        # The mass matrix is diagonal and constant: the ball is a sphere on a free joint, and each rod slides
        # along and turns about the same axis from the world (x . (x cross r) = 0 couples nothing).
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass)
        self.mass_diagonal = np.diag(mass).copy()
        if np.abs(mass - np.diag(self.mass_diagonal)).max() > 1e-9 * self.mass_diagonal.max():
            raise ValueError("the impact solver needs a diagonal mass matrix (a free ball and rods on the world)")
        self._gaps = [-1.0, -1.0]  # walls', figures'
        self._steps_since_gaps = 0
        self._jac_ball = np.zeros((3, model.nv))
        self._jac_other = np.zeros((3, model.nv))
        self._post_shift: np.ndarray | None = None
        self.touching = NOT_TOUCHING  # whether a figure of each team was hit, or is in contact, in this step
        # The rods (their rotation dofs) whose figures can reach the ball in the next step, or None for every rod
        # (set_reachable: on the jerk-limited drives foos_sim.sweeps knows). A fast ball's look-ahead reports a
        # figure spinning 55 mm away, and solved with the others, linearised, it threw the ball at 82 m/s.
        self.reachable: frozenset | None = None

    # --- look-ahead --------------------------------------------------------------------------------
    def update_gaps(self, data: mujoco.MjData) -> None:
        """Let the impact pairs see one step ahead at the ball's current speed (and a figure's fastest), each
        gap changed only when it is 25 % off. Before the first step; after_step keeps them up to date."""
        self._steps_since_gaps = 0
        vx, vy, vz = data.qvel[self.ball_qvel:self.ball_qvel + 3].tolist()
        self._set_gaps(math.sqrt(vx * vx + vy * vy + vz * vz))

    def set_motion(self, data: mujoco.MjData, figure_speed: float, timestep: float) -> None:
        """The next steps' length (a sub-step, for a fast figure near the ball) and the fastest a figure near
        the ball moves in them; the gaps widen at once and narrow with the next refresh."""
        if timestep != self.timestep or figure_speed > self.figure_speed_limit:
            self.timestep = timestep
            self.figure_speed_limit = figure_speed
            self.update_gaps(data)
        elif figure_speed < 0.6 * self.figure_speed_limit:
            self.figure_speed_limit = figure_speed  # the gaps follow within GAP_REFRESH_STEPS

    def _set_gaps(self, speed: float) -> None:
        h, gaps = self.timestep, self._gaps
        wall_gap = 1.25 * speed * h + 0.001
        if wall_gap > gaps[0] or wall_gap < 0.6 * gaps[0]:
            gaps[0] = 1.25 * wall_gap
            self.model.pair_gap[self.wall_pairs] = gaps[0]
        figure_gap = 1.25 * (speed + self.figure_speed_limit) * h + 0.001
        if figure_gap > gaps[1] or figure_gap < 0.6 * gaps[1]:
            gaps[1] = 1.25 * figure_gap
            self.model.pair_gap[self.figure_pairs] = gaps[1]

    # --- one step ----------------------------------------------------------------------------------
    def resolve(self, data: mujoco.MjData) -> bool:
        """After mj_step1: apply this step's impacts. True when qpos/qvel changed (run mj_step1 again)."""
        self.touching = NOT_TOUCHING
        ncon = data.ncon
        if ncon:
            # Every contact is one of the ball's pairs: the other geom is the pair's sum less the ball. MuJoCo
            # collides the pairs in order, floors first, so a last contact with a floor means floors only.
            ball, wall_or_figure = self.ball_geom, self.wall_or_figure
            contacts = data.contact
            geoms = contacts.geom[:ncon].tolist()
            g1, g2 = geoms[-1]
            if wall_or_figure[g1 + g2 - ball]:
                # _may_strike, inlined (it runs for every contact of every step with a wall or figure near the ball)
                rod_of, reachable = self.rod_of, self.reachable
                near = [i for i, (g1, g2) in enumerate(geoms)
                        if wall_or_figure[g1 + g2 - ball]
                        and (reachable is None or rod_of[g1 + g2 - ball] is None or rod_of[g1 + g2 - ball][2] in reachable)]
                if near:
                    return self._screen(data, contacts, near, geoms)
        vz = float(data.qvel[self.ball_qvel + 2])
        if vz < -self.field_min_speed and self._landing(data):
            return self._resolve_impacts(data, self._contacts_for_impacts(data))
        return False

    def _may_strike(self, geom: int) -> bool:
        """A wall, or a figure whose rod can reach the ball in this step."""
        if not self.wall_or_figure[geom]:
            return False
        rod = self.rod_of[geom]
        return rod is None or self.reachable is None or rod[2] in self.reachable

    def _contacts_for_impacts(self, data: mujoco.MjData) -> "_Contacts":
        """Every wall and figure near the ball, walls as far as the ball can get in a step once a figure has
        struck it (twice a figure's speed more): a step's impacts are solved together, and a ball struck
        into a wall 4 mm away went 3 mm into it when the wall was not among them. MuJoCo's collision runs
        again with the walls' gap widened for it; the step's own collision runs after the impacts."""
        vx, vy, vz = data.qvel[self.ball_qvel:self.ball_qvel + 3].tolist()
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        wide_gap = 1.25 * (speed + 2.0 * self.figure_speed_limit) * self.timestep + 0.001
        x, y, z = data.qpos[self.ball_qpos:self.ball_qpos + 3].tolist()
        room = wide_gap + self.ball_radius  # no wall nearer than this to the ball's centre: nothing to add
        if abs(x) > self.field_half[0] - room or abs(y) > self.field_half[1] - room or z > self.cover_height - room:
            self.model.pair_gap[self.wall_pairs] = wide_gap
            mujoco.mj_collision(self.model, data)
            self.model.pair_gap[self.wall_pairs] = self._gaps[0]
        ncon, ball = data.ncon, self.ball_geom
        listed = []
        for i, (g1, g2) in enumerate(data.contact.geom[:ncon].tolist()):
            other = g1 + g2 - ball
            if self._may_strike(other):
                listed.append((i, other, -1.0 if g1 == ball else 1.0))  # MuJoCo's normal points from geom1 to geom2
        return _Contacts.of(self, data, listed)

    def _screen(self, data: mujoco.MjData, contacts, near: list[int], geoms: list) -> bool:
        """The walls and figures reported near the ball: is one hit in this step? Before any Jacobian: a
        surface is hit when the relative normal velocity closes the gap within the step (a figure point's
        velocity from its rod's slide and rotation)."""
        ball, h = self.ball_geom, self.timestep
        qvel = data.qvel.tolist()
        b = self.ball_qvel
        vx, vy, vz = qvel[b], qvel[b + 1], qvel[b + 2]
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        figure_reach = (speed + self.figure_speed_limit) * h
        due = False
        touching = None
        ncon = len(geoms)
        dists, frames = contacts.dist[:ncon].tolist(), contacts.frame[:ncon, :3].tolist()
        positions = xpos = None
        for i in near:
            g1, g2 = geoms[i]
            other, sign = (g2, -1.0) if g1 == ball else (g1, 1.0)  # MuJoCo's normal points from geom1 to geom2
            surface = self.surface_of[other]
            rod = self.rod_of[other]
            dist = dists[i]
            if dist < 0.0 and surface.team >= 0:
                touching = touching or [False] * len(TEAMS)
                touching[surface.team] = True  # in contact with a figure (a push, a pinch), impact or not
            if due or (rod is not None and dist > figure_reach):
                continue
            nx, ny, nz = frames[i]
            u = nx * vx + ny * vy + nz * vz
            if rod is not None:
                body, slide, rotate = rod
                if positions is None:
                    positions, xpos = contacts.pos[:ncon].tolist(), data.xpos.tolist()
                px, py, pz = positions[i]
                cx, cy, cz = xpos[body]
                w = qvel[rotate]  # about +x: a point moves by w x (p - c) = w (0, -(pz - cz), py - cy)
                u -= nx * qvel[slide] - ny * w * (pz - cz) + nz * w * (py - cy)
            u *= sign
            # An overlap is cleared even when not closing. A foot's corner sweeping over the ball closes the gap
            # faster than a straight line through it (1.2 mm in a step at 40 rad/s), and the stiff contact,
            # pushing the ball out with the foot's friction and with no floor contact yet (the ball a little
            # above it), sent it 10 mm into the field; so every figure overlap is cleared, with the floor and
            # the walls near the ball kept clear too. A wall's holds what rests against it.
            due = (u < -surface.min_speed and dist + u * h < 0.0) or dist < (0.0 if rod is not None else -OVERLAP_TOLERANCE)
        if touching is not None:
            self.touching = touching
        if not due and vz < -self.field_min_speed:
            due = self._landing(data)
        if not due:
            return False
        return self._resolve_impacts(data, self._contacts_for_impacts(data))

    def _landing(self, data: mujoco.MjData) -> bool:
        """Whether a falling ball meets the floor (met as the plane it stands for, floor_below) in this step."""
        # floor_below's test without its arrays: the floor's normal is +z, so the ball's normal velocity is vz.
        z = float(data.qpos[self.ball_qpos + 2])
        gap = z - self.ball_radius
        vx, vy, vz = data.qvel[self.ball_qvel:self.ball_qvel + 3].tolist()
        if gap > (math.sqrt(vx * vx + vy * vy + vz * vz) + self.figure_speed_limit) * self.timestep:
            return False
        return vz < -self.field_min_speed and gap + vz * self.timestep < 0.0

    def after_step(self, data: mujoco.MjData) -> None:
        """After mj_step2: the rest of the impacts' position shift; the gaps, after an impact and every few
        steps (they keep a quarter to spare, and between impacts the ball's speed changes slowly)."""
        if self._post_shift is not None:
            data.qpos[self.ball_qpos:self.ball_qpos + 3] += self._post_shift
            self._post_shift = None
        self._steps_since_gaps += 1
        if self._steps_since_gaps >= GAP_REFRESH_STEPS:
            self.update_gaps(data)

    # --- internals ---------------------------------------------------------------------------------
    def floor_below(self, data: mujoco.MjData) -> tuple[float, np.ndarray, np.ndarray] | None:
        """(gap, normal, point) of the floor under the ball when it is within a step's reach, else None.

        The floor is the plane z = 0 (the field and the goal floors; the fast physics keeps the field flat,
        see foos_sim.effects.DentSlopes). MuJoCo's floor contacts hold the ball at rest and rolling; they
        take no look-ahead gap, so the impacts meet the plane itself."""
        x, y, z = data.qpos[self.ball_qpos:self.ball_qpos + 3].tolist()
        gap = z - self.ball_radius
        vx, vy, vz = data.qvel[self.ball_qvel:self.ball_qvel + 3].tolist()
        if gap > (math.sqrt(vx * vx + vy * vy + vz * vz) + self.figure_speed_limit) * self.timestep:
            return None
        return gap, np.array([0.0, 0.0, 1.0]), np.array([x, y, 0.0])

    def contact_jacobian(self, data: mujoco.MjData, point: np.ndarray, other_geom: int) -> np.ndarray:
        """3 x nv: the velocity of the ball's point minus the other body's point at `point`."""
        mujoco.mj_jac(self.model, data, self._jac_ball, None, point, self.ball_body)
        jac = self._jac_ball.copy()
        other_body = self.geom_body[other_geom]
        if other_body != 0:
            mujoco.mj_jac(self.model, data, self._jac_other, None, point, other_body)
            jac -= self._jac_other
        return jac

    def _resolve_impacts(self, data: mujoco.MjData, c: "_Contacts") -> bool:
        h = self.timestep
        qvel = data.qvel
        ball_v = qvel[self.ball_qvel:self.ball_qvel + 3]
        v_start = ball_v.copy()
        u0 = c.jac_normal @ qvel
        # Overlaps are cleared first, so each contact's gap is what the step starts from.
        separation = self._clear_overlaps(c)  # in velocity coordinates: the ball's move and the rods'
        gap = c.dist + c.jac_normal @ separation
        pre_shift = separation[self.ball_qvel:self.ball_qvel + 3]
        # First as if every drive held with its damping; one that would need more than its force limit over
        # the contact gives way, pushing back with that limit (the goalie's single figure, hit at 5 m/s,
        # returned 0.48 of the ball's speed against the reference's 0.34 before).
        damping, servo_push = self.drive_damping.copy(), np.zeros(self.model.nv)
        for _ in range(3):
            inverse_mass = 1.0 / (self.mass_diagonal + damping)
            impulse, velocity_change, w_nn = self._normal_impulses(c, u0, gap, inverse_mass, servo_push)
            over = (damping > 0.0) & (np.abs(damping * velocity_change) > self.drive_impulse_limit)
            if not np.count_nonzero(over):
                break
            damping[over] = 0.0
            servo_push[over] = -np.sign(velocity_change[over]) * self.drive_impulse_limit[over]
        qvel += velocity_change
        hit = np.flatnonzero(impulse > 0.0)
        for i in hit:
            self._apply_friction(qvel, c, int(i), float(impulse[i]), inverse_mass)
            if c.team[i] >= 0:
                self.touching = [*self.touching]
                self.touching[c.team[i]] = True
        # Friction at one contact can drive the ball into another (a foot's friction pressing it into the
        # field, by up to 3 m/s): those contacts stop it, inelastically.
        u2 = c.jac_normal @ qvel
        closing = np.flatnonzero((u2 < -c.min_speed) & (gap + u2 * h < 0.0))
        if closing.size:
            stop = solve_lcp(w_nn[closing][:, closing], u2[closing])
            qvel += inverse_mass * (c.jac_normal[closing].T @ stop)
        self._steps_since_gaps = GAP_REFRESH_STEPS  # the ball's speed has changed: new gaps after this step
        if np.count_nonzero(separation):
            mujoco.mj_integratePos(self.model, data.qpos, separation, 1.0)
        if hit.size == 1:
            # The bounce happened t* = gap / |u| into the step (negative: the overlap shows it was already
            # due, at most a step ago); place the ball as an instantaneous bounce then would have it, but
            # short of any surface it would reach by the end of the step (a ball falling onto the edge of
            # a goal floor bounces off the edge late in the step, and would be shifted through the field).
            i = int(hit[0])
            t_star = min(max(c.dist[i] / -u0[i], -h), h)
            shift = (v_start - ball_v) * t_star - pre_shift
            gap_at_end = gap + (c.jac_normal @ qvel) * h
            # The least change of the shift that keeps every gap at the end of the step open: s = shift + N^T l;
            # none where that is no small change (the ball squeezed between nearly opposite surfaces).
            shift = shift + c.normal.T @ solve_lcp(c.normal @ c.normal.T, c.normal @ shift + gap_at_end)
            if shift @ shift <= (2.0 * np.abs(v_start - ball_v).max() * h + 1e-3) ** 2:
                self._post_shift = shift
        return True

    def _normal_impulses(self, c: "_Contacts", u0: np.ndarray, gap: np.ndarray, inverse_mass: np.ndarray,
                         servo_push: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The normal impulses of a step's impacts (k), the velocity change they make (nv), and the contacts'
        normal coupling W_nn = Jn M^-1 Jn^T, with the drives' damping and the push of those at their limit."""
        h, jn = self.timestep, c.jac_normal
        w_nn = (jn * inverse_mass) @ jn.T
        pushed = servo_push * inverse_mass
        u_pushed = u0 + jn @ pushed
        # Impacts due now; a contact joins when the others' impulses make it due (a foot striking down
        # sends the ball into the field).
        due = (u0 < -c.min_speed) & ((c.dist < 0.0) | (gap + u0 * h < 0.0))
        impulse = np.zeros(len(u0))
        for _ in range(len(u0)):
            idx = np.flatnonzero(due)
            # Newton's restitution on each impact: w = u' + e u >= 0, impulse >= 0, complementary.
            q = u_pushed[idx] + c.restitution[idx] * np.minimum(u0[idx], 0.0)
            impulse[:] = 0.0
            impulse[idx] = solve_lcp(w_nn[idx][:, idx], q)
            u1 = u_pushed + w_nn @ impulse
            joining = ~due & (u1 < -c.min_speed) & (gap + u1 * h < 0.0)
            if not np.count_nonzero(joining):
                break
            due |= joining
        if not np.count_nonzero(impulse):
            return impulse, np.zeros_like(pushed), w_nn
        return impulse, inverse_mass * (jn.T @ impulse) + pushed, w_nn

    def _apply_friction(self, qvel: np.ndarray, c: "_Contacts", i: int, normal_impulse: float,
                        inverse_mass: np.ndarray) -> None:
        """Stop contact i's tangential velocity within mu times its normal impulse (sliding past that)."""
        n, jac = c.normal[i], c.jac[i]
        v_rel = jac @ qvel
        tangential = v_rel - (v_rel @ n) * n
        speed = math.sqrt(float(tangential @ tangential))
        if speed < 1e-12:
            return
        direction = -tangential / speed
        jac_t = direction @ jac  # the slip direction's row of the Jacobian
        # Impulse along the slip to stop it: the inverse inertia seen along that direction.
        stopping = speed / float((jac_t * inverse_mass) @ jac_t)
        qvel += inverse_mass * jac_t * min(c.friction_share[i] * stopping, c.friction[i] * normal_impulse)

    def _clear_overlaps(self, c: "_Contacts") -> np.ndarray:
        """The least move (weighted by mass, in velocity coordinates) of the ball and the rods that clears
        every overlap and closes no other listed gap: the ball moves out of a figure, and where it cannot (a
        foot pressing it onto the field, a figure squeezing it against a wall) the rod gives way. Moving the
        ball alone left a pressed ball 5 mm inside the foot for tens of steps (MuJoCo's contact, stiff as it
        may be at 2 ms, corrects an overlap at 0.3 m/s per mm)."""
        overlapping = (c.dist < 0.0) & ~c.is_floor
        if not np.count_nonzero(overlapping):
            return np.zeros(self.model.nv)
        # Minimise |dq|_M subject to gap_i + Jn_i dq >= 0 (a clearance more where overlapping): dq = M^-1 Jn^T l.
        # A surface the move presses the ball against is left just touching it (TOUCHING deep), so that its
        # contact is among MuJoCo's in the step: a ball cleared from a foot onto the field at a gap of
        # exactly 0 had no field contact, and the foot, pushed on by its drive, sent it 8 mm into the field.
        limit = np.where(overlapping, np.where(c.is_figure, FIGURE_CLEARANCE, CLEARANCE) - c.dist, -TOUCHING - c.dist)
        # The floor is not cleared (the ball rests on it): not pressed deeper than it is, or TOUCHING.
        limit[c.is_floor] = np.minimum(c.dist[c.is_floor], -TOUCHING) - c.dist[c.is_floor]
        weighted = c.jac_normal / self.mass_diagonal
        move = weighted.T @ solve_lcp(weighted @ c.jac_normal.T, -limit)
        ball_move = move[self.ball_qvel:self.ball_qvel + 3]
        if np.any(c.jac_normal @ move < limit - 1e-5) or ball_move @ ball_move > (2.0 * limit.max() + 0.001) ** 2:
            # No consistent move (nearly opposite surfaces, which the ball could leave only far along them):
            # MuJoCo's contacts take the squeeze. The floor's must be among them: a ball a little above it
            # is set down on it (with a foot pressing it down, and the field's contact missing, it went
            # through the field).
            move[:] = 0.0
            floor = np.flatnonzero(c.is_floor & (c.dist >= 0.0) & (c.dist < FLOOR_SNAP))
            if floor.size:
                i = int(floor[0])
                move[self.ball_qvel:self.ball_qvel + 3] = -(c.dist[i] + TOUCHING) * c.normal[i]
        return move

@dataclass
class _Contacts:
    """The impact surfaces near the ball in one step, as arrays (k contacts)."""

    dist: np.ndarray  # k, m
    normal: np.ndarray  # k x 3, from the other surface to the ball
    jac: np.ndarray  # k x 3 x nv, ball point minus the other body's point
    jac_normal: np.ndarray  # k x nv, the normal's row of each
    restitution: np.ndarray
    friction: np.ndarray
    min_speed: np.ndarray
    friction_share: np.ndarray
    team: list
    is_floor: np.ndarray
    is_figure: np.ndarray

    @classmethod
    def of(cls, solver: ImpactSolver, data: mujoco.MjData, listed: list) -> "_Contacts":
        contact = data.contact
        # Each array read once (every read of a contact field builds the whole array).
        dists, frames, positions = contact.dist, contact.frame, contact.pos
        surfaces = [solver.surface_of[other] for _, other, _ in listed]
        dist = [float(dists[i]) for i, _, _ in listed]
        normal = [sign * frames[i, :3] for i, _, sign in listed]
        jac = [solver.contact_jacobian(data, positions[i], other) for i, other, _ in listed]
        # The floor under the ball takes part when within a step's reach: a foot striking down presses the
        # ball into it.
        floor = solver.floor_below(data)
        if floor is not None:
            dist.append(floor[0])
            normal.append(floor[1])
            jac.append(solver.contact_jacobian(data, floor[2], solver.field_geom))
            surfaces.append(solver.surface_of[solver.field_geom])
        normal, jac = np.array(normal), np.array(jac)
        return cls(
            dist=np.array(dist),
            normal=normal,
            jac=jac,
            jac_normal=np.einsum("ij,ijk->ik", normal, jac),
            restitution=np.array([s.restitution for s in surfaces]),
            friction=np.array([s.friction for s in surfaces]),
            min_speed=np.array([s.min_speed for s in surfaces]),
            friction_share=np.array([s.friction_share for s in surfaces]),
            team=[s.team for s in surfaces],
            is_floor=np.array([s.floor for s in surfaces], dtype=bool),
            is_figure=np.array([s.team >= 0 for s in surfaces], dtype=bool),
        )
