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


class ImplicitForceLimits:
    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData):
        self.model = model
        self.limit = model.actuator_forcerange[:, 1].copy()  # every drive's, for efforts()
        gain = model.actuator_gainprm[:, 0]  # kv of each velocity servo
        dofs = model.jnt_dofadr[model.actuator_trnid[:, 0]]
        timestep = float(model.opt.timestep)
        mujoco.mj_forward(model, data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, full)
        # A rod's slide and rotation are decoupled and its inertia does not change as it turns.
        inertia = full[dofs, dofs]
        self.actuators = np.flatnonzero(gain * timestep > inertia)  # the drives that can overshoot
        self.dofs = dofs[self.actuators]
        a = self.actuators
        # The implicit step of the servo alone ends at command - (command - velocity) I / (I + h kv): within
        # the limit while |command - velocity| <= limit (I + h kv) / (kv I).
        self.lift_below = self.limit[a] * (inertia[a] + timestep * gain[a]) / (gain[a] * inertia[a])
        self._lifted = b""
        self._quiet = False
        # Views into the simulation's arrays and scratch buffers: this runs before every step.
        self._ctrl, self._qvel = data.ctrl, data.qvel
        self._command = np.zeros(len(a))
        self._error = np.zeros(len(a))
        self._within = np.zeros(len(a), dtype=bool)

    def disturb(self) -> None:
        """A command changed or a rod was jolted: check before the next step."""
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
