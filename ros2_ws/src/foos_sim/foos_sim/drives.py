"""The rod drives' force limits, decided at the end of each step as the implicit integrator sees them.

A drive is a velocity servo (force = kv (command - velocity)) clipped to its force limit. MuJoCo clips
with the velocity at the start of a step and then drops the servo from the implicit integration, so
at the fast physics' 2 ms a rotation drive (kv h / I = 5) overshoots: from rest, commanded 40 rad/s,
it reached 26, 53, 26, 53 ... rad/s, and a kick left 4.0 m/s instead of 3.3 (the 20 kHz reference).
The servo's own time constant (I / kv, 0.3 ms) is shorter than a step, so the drive ends a step at
its command unless it needs more than its force limit to get there. ImplicitForceLimits lifts the
limit of every drive whose implicit step ends within it, before each step, and keeps the others.

Only a drive with kv h > I can overshoot (its clipped step, h F / I, is larger than the error at which
it clips, F / kv): the rotations. The slides (kv h / m < 1) keep MuJoCo's own clipping, which also holds
a slide at its travel stop with no more than its force limit. Once every rotation is within its limit,
nothing changes that until a command does or an impact jolts a rod (ImplicitForceLimits.disturb).
"""
from __future__ import annotations

import mujoco
import numpy as np

UNLIMITED = 1e9  # N or N m: a force range MuJoCo never reaches
STOP_ZONE = 0.001  # m short of a travel stop from which a slide driven toward it is left to its servo


class ImplicitForceLimits:
    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData):
        self.model = model
        self.limit = model.actuator_forcerange[:, 1].copy()  # every drive's, for efforts()
        self._gain = model.actuator_gainprm[:, 0].copy()  # kv of each velocity servo
        self._all_dofs = model.jnt_dofadr[model.actuator_trnid[:, 0]]
        mujoco.mj_forward(model, data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        # A rod's slide and rotation are decoupled and its inertia does not change as it turns.
        self._inertia = full[self._all_dofs, self._all_dofs]
        self._ctrl, self._qvel = data.ctrl, data.qvel  # views: this runs before every step
        self._configs: dict[float, tuple] = {}
        self.timestep = 0.0
        self.set_timestep(float(model.opt.timestep))

    def set_timestep(self, timestep: float) -> None:
        """The step the next updates are for (a sub-step of the fast physics overshoots less)."""
        if timestep == self.timestep:
            return
        if self.timestep and len(self.actuators):
            # Leave the drives of the old step at their own limits before switching.
            self.model.actuator_forcerange[self.actuators, 0] = -self.limit[self.actuators]
            self.model.actuator_forcerange[self.actuators, 1] = self.limit[self.actuators]
        if timestep not in self._configs:
            if len(self._configs) > 8:  # a step split where a command arrives has a length of its own: keep a few
                self._configs.clear()
            gain, inertia = self._gain, self._inertia
            a = np.flatnonzero(gain * timestep > inertia)  # the drives that can overshoot
            # The implicit step of the servo alone ends at command - (command - velocity) I / (I + h kv): within
            # the limit while |command - velocity| <= limit (I + h kv) / (kv I).
            lift_below = self.limit[a] * (inertia[a] + timestep * gain[a]) / (gain[a] * inertia[a])
            self._configs[timestep] = (a, self._all_dofs[a], lift_below)
        self.actuators, self.dofs, self.lift_below = self._configs[timestep]
        self.timestep = timestep
        n = len(self.actuators)
        self._command, self._error, self._within = np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool)
        self._lifted = b""
        self._quiet = False

    def disturb(self) -> None:
        """A command changed or a rod was jolted: check before the next step."""
        self._quiet = False

    def after_impact(self) -> None:
        """An impact changed rod velocities within the step: the limits are checked again before the next."""
        self._quiet = False

    def update(self) -> None:
        """Before a step: lift the force limit of the drives that end this step within it."""
        if self._quiet:
            return
        error, within = self._error, self._within
        self._qvel.take(self.dofs, out=error)
        self._ctrl.take(self.actuators, out=self._command)
        np.subtract(self._command, error, out=error)
        np.abs(error, out=error)
        np.less_equal(error, self.lift_below, out=within)
        key = within.tobytes()
        if key != self._lifted:
            self._lifted = key
            bound = np.where(within, UNLIMITED, self.limit[self.actuators])
            self.model.actuator_forcerange[self.actuators, 0] = -bound
            self.model.actuator_forcerange[self.actuators, 1] = bound
        # An implicit servo's error only shrinks: once every drive is within its limit, it stays so.
        self._quiet = bool(within.all())

    def efforts(self, data: mujoco.MjData) -> np.ndarray:
        """Each drive's force over the last step: within its limit (a lifted drive reports its explicit force)."""
        return np.clip(data.actuator_force, -self.limit, self.limit)


class FollowingDrives:
    """The jerk-limited drives on the fast physics: a drive that can reach its target within its force limit in
    a step starts the step at it; the others push toward it at their limit (MuJoCo's clipping).

    The target is the drive's setpoint at the middle of the step (foos_sim.drive_profiles), and the servo's own
    time constant (inertia / gain, 0.2-4 ms) is what the 20 kHz reference resolves and a 2 ms step cannot:
    there the reference is fed the setpoint that far ahead, and follows it as closely. Starting the step at the
    target moves the rod as far as the setpoint moves, and gives the impacts (foos_sim.impacts) the velocity
    its figures move with through the step, not the one before it: a foot accelerating at 2000 rad/s^2 gains
    2 rad/s in a 1 ms sub-step, and kicks left 3-5 % slower than on the reference with the velocity before.
    A drive that needs more than its force limit (a jolt, a stop, a setpoint it lags) changes by less than its
    error in the step at its limit, so MuJoCo's clipping cannot overshoot it (foos_sim.drives'
    ImplicitForceLimits is for servos on the command itself). Same interface as ImplicitForceLimits.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData):
        self.model = model
        self.limit = model.actuator_forcerange[:, 1].copy()
        self._dofs = model.jnt_dofadr[model.actuator_trnid[:, 0]]
        mujoco.mj_forward(model, data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        self._inertia = full[self._dofs, self._dofs]
        # Views of the drives' targets and their joints' velocities (a slice where the dofs follow the actuators,
        # as the table's model has them: this runs before every step and sub-step).
        self._ctrl, self._qvel = data.ctrl, _view(data.qvel, self._dofs)
        self._moved_force = np.zeros(model.nu)  # what starting at the target took, for efforts()
        self._moved = False
        # The rule of update() runs compiled (foos_sim.following; numba imported only with these drives).
        from . import following
        self._follow = following.follow
        # Per drive (following's rows): its reach in a step, the change starting at its target takes, whether it did.
        self._lanes = np.zeros((3, model.nu))
        self._reach, self._change = self._lanes[following.REACH], self._lanes[following.CHANGE]
        self._within_row = self._lanes[following.WITHIN]
        # The drives with a travel stop (the slides): one driven into its stop pushes at its force limit only.
        joints = model.actuator_trnid[:, 0]
        self._stopped = _view(np.arange(model.nu), np.flatnonzero(model.jnt_limited[joints].astype(bool)))
        stopped = np.arange(model.nu)[self._stopped]
        self._stop_qpos = _view(data.qpos, model.jnt_qposadr[joints[stopped]])
        self._stops = np.array([stopped, model.jnt_range[joints[stopped], 0] + STOP_ZONE,
                                model.jnt_range[joints[stopped], 1] - STOP_ZONE], dtype=float)  # drive, low, high
        self._quiet = False
        self.timestep = 0.0
        self.set_timestep(float(model.opt.timestep))

    def set_timestep(self, timestep: float) -> None:
        self.timestep = timestep
        self._reach[:] = self.limit * timestep / self._inertia  # the most a drive's velocity changes in a step
        self._quiet = False

    def disturb(self) -> None:
        """A target changed or a rod was jolted: check before the next step."""
        self._quiet = False

    def after_impact(self) -> None:
        """An impact jolted a rod (after the step's start): a drive that reaches its target within its limit is
        back at it in this step, as an implicit servo ends the step; MuJoCo's clipped servo pushing on through
        the step overshot (a goalie struck at 5 m/s swung at 57 rad/s into the ball and returned 0.8 of its
        speed, the reference 0.38)."""
        self._quiet = False
        self.update()

    def update(self) -> None:
        """Before a step: the drives that reach their targets within their limits start the step there."""
        if self._quiet:
            self._moved = False
            return
        self._moved = True
        # Once every drive is at its target, nothing changes that until a target does or a rod is jolted.
        self._quiet = self._follow(self._ctrl, self._qvel, self._stop_qpos, self._lanes, self._stops)

    def efforts(self, data: mujoco.MjData) -> np.ndarray:
        """Each drive's force over the last step: its servo's and what starting at the target took."""
        moved = self._moved_force
        moved[:] = 0.0
        if self._moved:
            np.multiply(self._change, self._inertia / self.timestep, out=moved)
            moved[self._within_row == 0.0] = 0.0
        return np.clip(data.actuator_force + moved, -self.limit, self.limit)


def _view(array: np.ndarray, index: np.ndarray) -> np.ndarray:
    """array[index] as a view: the table's model numbers its rods' dofs, qpos and actuators evenly (a slice)."""
    index = np.asarray(index)
    step = int(index[1] - index[0]) if len(index) > 1 else 1
    if step <= 0 or np.any(index != index[0] + step * np.arange(len(index))):
        raise ValueError("FollowingDrives needs the drives' joints numbered evenly in the model's arrays")
    return array[index[0]:index[-1] + 1:step]
