"""Swimming observables of a robot in a fluid: forward motion, the fluid's force, its cost.

History columns (:class:`Swimming`), SI, strips' forces per unit depth
times the depth:

* ``swim_distance``: the centre of mass's displacement along the swimming
  direction e (m), ``swim_speed`` its velocity along e (m/s) and
  ``com_x``, ``com_y``, ``com_z`` (m);
* ``fluid_force_x|y|z`` (N): the fluid's force on the body (drag, skin
  friction, added mass; buoyancy excluded), ``fluid_thrust`` its normal
  (pressure) part along e and ``fluid_friction`` its tangential part along e
  (N): thrust is what the normal forces of the strokes give, friction what
  the skin drag takes;
* ``fluid_power`` (W): the power the body gives the fluid, and
  ``fluid_work`` (J) its time integral: the added mass's kinetic energy
  gained since the start plus the drag's and skin friction's work
  (trapezoidal rule over the samples). The added mass's power is the rate
  of its kinetic energy exactly, so its work is taken as that energy's
  change rather than summed from sampled powers, which would carry the
  integrator's acceleration error;
* ``fluid_kinetic`` (J): the kinetic energy of the added mass, ∫ ½ m_a v_n² da
  (fluid_work − fluid_kinetic + its start value is what the fluid
  dissipated: never negative);
* ``fluid_reynolds``: Re = v_rms b/ν of the root-mean-square normal speed
  over the wetted faces;
* ``cost_of_transport``: fluid_work / (m g |swim_distance|), the energy given
  to the fluid per weight and distance (dimensionless; nan before any
  displacement);
* 3D bodies swimming horizontally: ``roll`` and ``pitch`` (rad, unwrapped),
  the rotation about e of the body's mean lateral material axis
  ∫ F l / ∫ 1 (l = e_z × e) and about l of its mean axis ∫ F e / ∫ 1: a
  propeller's twist, a swimmer's nose up or down.

Summary (:func:`summarize_swimming`): the final distance and cost of
transport, and over the last complete drive period the mean forward speed
(distance gained over the period / period), the mean thrust and friction,
and per arm the stroke amplitude, half the peak-to-peak tip angle (and of
the roll and pitch).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import ufl

from magfem.mechanics.forms import ScalarForms
from magfem.mechanics.observers.base import Observer

__all__ = ["STANDARD_WEIGHT_GRAVITY", "Swimming", "summarize_swimming"]

STANDARD_WEIGHT_GRAVITY = 9.80665
"""g₀ (m/s²) of the weight in the cost of transport."""


class Swimming(Observer):
    """Columns of the module docstring (collective).

    Args:
        mass_density: mass per unit of the measure ``dx`` (UFL).
        dx: the model's cell measure.
        position, velocity: current position x = X + u and velocity v (UFL
            gdim-vectors at the accepted state).
        fluid_forms: the fluid load's forms at the accepted state
            (:meth:`magfem.mechanics.loads.fluid.FluidLoad.observed_forms`).
        direction: the swimming direction e (3 components, any length).
        gdim: the mesh's geometric dimension (2 for strips: (x, z)).
        kinematic_viscosity: ν (m²/s). chord: b (m).
        depth: a strip's depth (m), 1 for 3D models.
        mesh: the mesh of the forms.
    """

    def __init__(
        self,
        *,
        mass_density: Any,
        dx: Any,
        position: Any,
        velocity: Any,
        fluid_forms: Mapping[str, Any],
        direction: Sequence[float],
        gdim: int,
        kinematic_viscosity: float,
        chord: float,
        depth: float,
        mesh: Any,
    ):
        e = np.asarray(direction, dtype=float)
        self.direction = (e if gdim == 3 else e[::2]) / np.linalg.norm(e)
        self.labels = "xyz" if gdim == 3 else "xz"
        mass = [mass_density * dx]
        mass += [mass_density * position[i] * dx for i in range(gdim)]
        mass += [mass_density * velocity[i] * dx for i in range(gdim)]
        self.axes = _axes(direction) if gdim == 3 else None
        if self.axes is not None:
            grad = ufl.grad(position)
            e, lateral = self.axes
            mass += [
                ufl.dot(grad[i, :], ufl.as_vector(axis)) * dx
                for axis in (lateral, e)
                for i in range(3)
            ]
        self.names = list(fluid_forms)
        self.forms = ScalarForms(mesh, mass + list(fluid_forms.values()))
        self.angles = np.zeros(2)
        self.gdim, self.depth = gdim, depth
        self.nu, self.chord = kinematic_viscosity, chord
        self.start: npt.NDArray[np.float64] | None = None
        self.drag_work = 0.0
        self.kinetic0: float | None = None
        self.last: tuple[float, float] | None = None

    def columns(self) -> list[str]:
        return [
            "swim_distance",
            "swim_speed",
            "com_x",
            "com_y",
            "com_z",
            *(f"fluid_force_{k}" for k in self.labels),
            "fluid_thrust",
            "fluid_friction",
            "fluid_power",
            "fluid_work",
            "fluid_kinetic",
            "fluid_reynolds",
            "cost_of_transport",
            *(["roll", "pitch"] if self.axes is not None else []),
        ]

    def observe(self, t: float) -> dict[str, float]:
        values = self.forms.assemble()
        g = self.gdim
        mass = values[0]
        com = np.asarray(values[1 : 1 + g]) / mass
        velocity = np.asarray(values[1 + g : 1 + 2 * g]) / mass
        rest = values[1 + 2 * g :]
        if self.axes is not None:
            self._turn(np.asarray(rest[:6]))
            rest = rest[6:]
        fluid = dict(zip(self.names, rest, strict=True))
        if self.start is None:
            self.start = com.copy()
        distance = float(np.dot(com - self.start, self.direction))
        drag_power = fluid["fluid_drag_power"] * self.depth
        if self.last is not None:
            self.drag_work += 0.5 * (drag_power + self.last[1]) * (t - self.last[0])
        self.last = (t, drag_power)
        kinetic = fluid["fluid_kinetic"] * self.depth
        if self.kinetic0 is None:
            self.kinetic0 = kinetic
        work = self.drag_work + kinetic - self.kinetic0
        com3 = com if g == 3 else np.array([com[0], 0.0, com[1]])
        row = {
            "swim_distance": distance,
            "swim_speed": float(np.dot(velocity, self.direction)),
            "com_x": float(com3[0]),
            "com_y": float(com3[1]),
            "com_z": float(com3[2]),
            "fluid_power": fluid["fluid_power"] * self.depth,
            "fluid_work": work,
            "fluid_kinetic": kinetic,
        }
        forces = ("fluid_thrust", "fluid_friction", *(f"fluid_force_{k}" for k in self.labels))
        for key in forces:
            row[key] = fluid[key] * self.depth
        rms = math.sqrt(max(fluid["fluid_normal_speed2"], 0.0) / fluid["fluid_area"])
        row["fluid_reynolds"] = rms * self.chord / self.nu
        weight = mass * self.depth * STANDARD_WEIGHT_GRAVITY
        moved = abs(distance) > 1e-6 * self.chord
        row["cost_of_transport"] = work / (weight * abs(distance)) if moved else math.nan
        if self.axes is not None:
            row["roll"], row["pitch"] = float(self.angles[0]), float(self.angles[1])
        return row

    def state(self) -> dict[str, Any]:
        """What the columns remember: the start, the work so far, the unwrapped turns."""
        return {
            "start": None if self.start is None else self.start.tolist(),
            "drag_work": self.drag_work,
            "kinetic0": self.kinetic0,
            "last": None if self.last is None else list(self.last),
            "angles": self.angles.tolist(),
        }

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        start, last = state["start"], state["last"]
        self.start = None if start is None else np.asarray(start, dtype=float)
        self.drag_work = float(state["drag_work"])
        self.kinetic0 = state["kinetic0"]
        self.last = None if last is None else (float(last[0]), float(last[1]))
        self.angles = np.asarray(state["angles"], dtype=float)

    def _turn(self, images: npt.NDArray[np.float64]) -> None:
        """Update the unwrapped (roll, pitch) from the mean images of l and e."""
        e, lateral = self.axes  # type: ignore[misc]
        up = np.array([0.0, 0.0, 1.0])
        ml, me = images[:3], images[3:]
        new = np.array(
            [
                math.atan2(float(ml @ up), float(ml @ lateral)),
                math.atan2(float(me @ up), float(me @ e)),
            ]
        )
        self.angles += (new - self.angles + math.pi) % (2 * math.pi) - math.pi


def _axes(direction: Sequence[float]) -> tuple[Any, Any] | None:
    """(e, l) of a horizontal swimming direction (unit 3-vectors), or None when e is vertical."""
    e = np.asarray(direction, dtype=float)
    e = e - e[2] * np.array([0.0, 0.0, 1.0])
    if np.linalg.norm(e) < 1e-6 * np.linalg.norm(direction):
        return None
    e /= np.linalg.norm(e)
    return e, np.cross([0.0, 0.0, 1.0], e)


def _last_period(t: npt.NDArray[np.float64], frequency: float | None) -> Any:
    """Mask of the samples of the last complete drive period, or None."""
    if not frequency or t[-1] - t[0] < 1.0 / frequency - 1e-12:
        return None
    periods = math.floor((t[-1] - t[0]) * frequency + 1e-9)
    end = t[0] + periods / frequency
    return (t >= end - 1.0 / frequency - 1e-12) & (t <= end + 1e-12)


def summarize_swimming(
    history: Mapping[str, npt.NDArray[np.float64]], frequency: float | None
) -> dict[str, float]:
    """Summary scalars of the swimming columns (module docstring); {} without them.

    ``swim_distance`` (m) at the end and ``swim_distance_1period`` after the
    first period of the drive (interpolated; nan before it), ``cost_of_transport``,
    and over the last complete period (nan without one): ``swim_speed`` (m/s),
    ``mean_thrust``, ``mean_friction`` (N), ``stroke_amplitude_<arm>`` and
    ``stroke_amplitude_roll``/``_pitch`` (rad).
    """
    if "swim_distance" not in history:
        return {}
    t = np.asarray(history["time"], dtype=float)
    distance = np.asarray(history["swim_distance"], dtype=float)
    first = t[0] + 1.0 / frequency if frequency else math.inf
    out = {
        "swim_distance": float(distance[-1]),
        "swim_distance_1period": float(np.interp(first, t, distance))
        if first <= t[-1]
        else math.nan,
        "cost_of_transport": float(history["cost_of_transport"][-1]),
    }
    window = _last_period(t, frequency)
    keys = ("swim_speed", "mean_thrust", "mean_friction")
    if window is None or np.count_nonzero(window) < 2:
        out |= dict.fromkeys(keys, math.nan)
        return out
    tw = t[window]
    span = tw[-1] - tw[0]
    out["swim_speed"] = float((distance[window][-1] - distance[window][0]) / span)
    for column, key in (("fluid_thrust", "mean_thrust"), ("fluid_friction", "mean_friction")):
        out[key] = float(np.trapezoid(np.asarray(history[column])[window], tw) / span)
    for column, values in history.items():
        if column.startswith("angle_") or column in ("roll", "pitch"):
            seen = np.asarray(values)[window]
            name = column.removeprefix("angle_")
            out[f"stroke_amplitude_{name}"] = float(0.5 * (seen.max() - seen.min()))
    return out
