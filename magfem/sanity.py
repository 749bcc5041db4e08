"""Warnings for valid but implausible cases: values that are legal and probably wrong.

Validation (:mod:`magfem.case`) rejects what cannot be simulated; the values
here can be simulated but are far from magfem's robots (fields of a few
millitesla, membranes 7-1000 µm thick, drives up to a few hundred hertz),
would take days, or start a free robot in a fluid with a step that throws
it. ``magfem check`` and ``magfem run`` print them as warnings
(:func:`implausible`); the run goes on. Two further warnings need the mesh
or the motion and come from the run itself: a support that holds most of
the body (:mod:`magfem.pipeline`), and a step after a field switch that
turns an arm by more than :data:`SWITCH_ROTATION` (:class:`SwitchWatch`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from magfem import material
from magfem.case import Case
from magfem.geometry.robots import outline_of
from magfem.mechanics.output import Writer

__all__ = [
    "MAX_ELEMENTS",
    "MAX_FIELD",
    "MAX_STEPS",
    "MIN_ROWS_PER_PERIOD",
    "MIN_SIZE_PER_THICKNESS",
    "MIN_STEPS_PER_PERIOD",
    "START_STEP_FRACTION",
    "SUPPORT_FRACTION",
    "SWITCH_ROTATION",
    "SwitchWatch",
    "implausible",
]

MAX_FIELD = 1.0
"""T: a nominal field above this at the robot is implausible (the robots work at 0.5-25 mT)."""
MIN_STEPS_PER_PERIOD = 10
"""A periodic drive resolved by fewer time steps per period is implausible."""
MIN_ROWS_PER_PERIOD = 20
"""A periodic drive sampled by fewer history rows per period (``[output] history_interval``)
is implausible: the summary's peaks and periods read the kept rows only."""
MAX_STEPS = 1_000_000
"""More time steps than this (at least one per switch and per nominal step) take days."""
MIN_SIZE_PER_THICKNESS = 0.25
"""An in-plane element size below this fraction of the thickness is implausible."""
MAX_ELEMENTS = 200_000
"""Elements (estimated from the area and the size) beyond which a run takes days on a laptop."""
SUPPORT_FRACTION = 0.5
"""Supports that hold more than this fraction of the body's nodes are implausible."""
START_STEP_FRACTION = 0.1
"""A free robot in a fluid whose field is on from the start should take a first step below
this fraction of the magnetoelastic time τ."""
SWITCH_ROTATION = math.radians(5.0)
"""rad: an arm that turns more than this in the step after a field switch is under-resolved."""


def implausible(case: Case) -> list[str]:
    """One line per implausible value of ``case`` (empty when nothing is)."""
    return [*_field(case), *_drive(case), *_start(case), *_mesh(case)]


def _field(case: Case) -> list[str]:
    lines = []
    for i, src in enumerate(case.field.sources):
        flux = getattr(src, "flux_density", None)
        if flux is not None and flux > MAX_FIELD:
            lines.append(
                f"field.sources[{i}].flux_density = {flux:.4g} T is above {MAX_FIELD:g} T "
                "(coils and magnets give the robots 0.5-25 mT); a missing unit?"
            )
    return lines


def _drive(case: Case) -> list[str]:
    time = case.time
    span = time.end - time.start
    lines = []
    steps = span / time.step
    for i, src in enumerate(case.field.sources):
        frequency = getattr(src.waveform, "frequency", None)
        if not frequency:
            continue
        per_period = 1.0 / (frequency * time.step)
        steps = max(steps, 2.0 * span * frequency)  # a step ends on every switch
        if per_period < MIN_STEPS_PER_PERIOD:
            lines.append(
                f"field.sources[{i}].waveform.frequency = {frequency:.4g} Hz: a period is "
                f"{per_period:.3g} time steps of time.step = {time.step:.3g} s (fewer than "
                f"{MIN_STEPS_PER_PERIOD}); the drive is not resolved"
            )
        interval = case.output.history_interval
        rows = 1.0 / (frequency * interval) if interval > 0.0 else math.inf
        if rows < MIN_ROWS_PER_PERIOD:
            lines.append(
                f"output.history_interval = {interval:.3g} s keeps {rows:.3g} rows per period "
                f"of field.sources[{i}] ({frequency:.4g} Hz; fewer than {MIN_ROWS_PER_PERIOD}): "
                "the history and its summary miss the peaks"
            )
    if steps > MAX_STEPS:
        lines.append(
            f"time: at least {steps:.3g} steps from {time.start:g} to {time.end:g} s "
            "(one per time.step and one per field switch); the run would take days"
        )
    return lines


def _start(case: Case) -> list[str]:
    """A long first step kicking a free robot in a fluid when the field is on from the start.

    A load switched on at the start makes generalized-α's first step
    overshoot in velocity by an amount that grows with the step; a free
    membrane in a fluid keeps what it was thrown (docs/fluid.md, "Strip
    theory's limit": a 2 ms start buckled the propeller, 0.05 ms did not).
    """
    time, mat = case.time, case.material
    if case.fluid is None or case.environment.clamped or time.scheme == "quasi_static":
        return []
    on = [s for s in case.field.sources if s.waveform.start <= time.start]
    flux = case.field.nominal_flux_bound()
    if not on or flux <= 0.0 or mat.remanence <= 0.0:
        return []
    tau = material.magnetoelastic_time(
        mat.shear_modulus, mat.bulk, case.robot.thickness, mat.density, mat.remanence, flux
    )
    if time.step <= START_STEP_FRACTION * tau:
        return []
    return [
        f"time.step = {time.step:.3g} s is more than {START_STEP_FRACTION:g} of the "
        f"magnetoelastic time ({tau:.3g} s): the field on from the start throws this free "
        "robot in its first step (generalized-alpha's overshoot, docs/fluid.md); start "
        f"with time.step <= {START_STEP_FRACTION * tau:.2g} s and let time.max_step grow it"
    ]


def _mesh(case: Case) -> list[str]:
    robot, mesh = case.robot, case.mesh
    lines = []
    if mesh.size < MIN_SIZE_PER_THICKNESS * robot.thickness:
        lines.append(
            f"mesh.size = {mesh.size:.3g} m is below {MIN_SIZE_PER_THICKNESS:g} of the "
            f"thickness ({robot.thickness:.3g} m): membranes are meshed with elements "
            "longer than they are thick"
        )
    elements = _estimated_elements(case)
    if elements > MAX_ELEMENTS:
        lines.append(
            f"mesh.size = {mesh.size:.3g} m gives about {elements:.3g} elements "
            f"(more than {MAX_ELEMENTS:.0e}); the run would take days"
        )
    return lines


def _estimated_elements(case: Case) -> float:
    """Elements of the robot's mesh estimated from its outline's area (strips: its length)."""
    mesh = case.mesh
    try:
        area = outline_of(case.robot).area
    except (ValueError, AttributeError):  # a shape without a closed outline: no estimate
        return 0.0
    layers = mesh.layers if mesh.model != "surface" else 1
    if mesh.model == "strip":
        length = area / (case.robot.uniform_width or 1.0)
        return length / mesh.size * layers
    return area / mesh.size**2 * layers


class SwitchWatch(Writer):
    """Warns once when an arm turns more than :data:`SWITCH_ROTATION` in the step after a switch.

    A writer of the run's rows (:class:`magfem.mechanics.output.Writer`): the
    step that starts on a switching instant of the field sees the new field
    at once; an arm that turns by several degrees in that one step is not
    resolved in time (a smaller ``time.step`` resolves it).

    Args:
        arms: the arm names (``angle_<arm>`` columns).
        switches: (t0, t1) -> switching instants in (t0, t1] (s).
        warn: called with the warning line.
    """

    def __init__(self, arms: Sequence[str], switches: Any, warn: Any):
        self.columns = [f"angle_{a}" for a in arms]
        self.switches = switches
        self.warn = warn
        self.warned = False
        self.previous: tuple[float, list[float]] | None = None
        self.on_switch = False

    def _on_switch(self, t: float) -> bool:
        """Whether t is a switching instant (steps land on them exactly)."""
        return bool(len(self.switches(t - 1e-12 * max(abs(t), 1.0), t)))

    def wants_row(self, step: int, t: float) -> bool:
        return self.on_switch or self._on_switch(t)

    def write(self, step: int, t: float, row: Mapping[str, float] | None) -> None:
        if row is None:  # not a switch nor the step after one (wants_row)
            self.previous, self.on_switch = None, False
            return
        angles = [float(row[c]) for c in self.columns]
        if self.previous is not None and self.on_switch and not self.warned:
            t0, before = self.previous
            turn = float(np.max(np.abs(np.subtract(angles, before)))) if angles else 0.0
            if turn > SWITCH_ROTATION:
                self.warned = True
                self.warn(
                    f"t = {t0:.6g} s: an arm turned {math.degrees(turn):.3g} deg in the step "
                    f"after a field switch (more than {math.degrees(SWITCH_ROTATION):g} deg); "
                    f"a smaller time.step (now {t - t0:.3g} s there) resolves the response"
                )
        self.on_switch = self._on_switch(t)  # the next step starts on a switch
        self.previous = (t, angles)

    def state(self) -> dict[str, Any]:
        """What a checkpoint keeps (:mod:`magfem.mechanics.checkpoint`)."""
        return {"warned": self.warned, "previous": self.previous, "on_switch": self.on_switch}

    def load_state(self, state: Mapping[str, Any]) -> None:
        """Continue from :meth:`state`."""
        self.warned = bool(state["warned"])
        previous = state["previous"]
        self.previous = None if previous is None else (float(previous[0]), list(previous[1]))
        self.on_switch = bool(state["on_switch"])
