"""Observers of a run (history columns) and the summary of a history."""

from magfem.mechanics.observers.arms import (
    ACTIVE_CURVATURE_FRACTION,
    CURVATURE_FLOOR,
    FOLD_ANGLE,
    MIDLINE_SAMPLES,
    TIP_OFFSET,
    AngleUnwrapper,
    ArmAngles,
    Midline,
    MidlineProbe,
    MidlineShape,
    arm_angle_points,
    bending_angle,
    bonded_length,
    midline_points,
    midline_samples,
    midline_shape,
)
from magfem.mechanics.observers.base import Observer, PointEvaluator
from magfem.mechanics.observers.body import BodyMotion, summarize_body
from magfem.mechanics.observers.energies import Energies
from magfem.mechanics.observers.field import AppliedField
from magfem.mechanics.observers.strain import Strain, StrainProbe
from magfem.mechanics.observers.summary import (
    COLLAPSE_FOLDS,
    COLLAPSE_TIP_LATERAL,
    NEAR_90,
    PARTIAL_SPREAD,
    bending_speed,
    first_crossing,
    history_summary,
    max_over_window,
    summarize_midline,
)
from magfem.mechanics.observers.swimming import Swimming, summarize_swimming

__all__ = [
    "ACTIVE_CURVATURE_FRACTION",
    "COLLAPSE_FOLDS",
    "COLLAPSE_TIP_LATERAL",
    "CURVATURE_FLOOR",
    "FOLD_ANGLE",
    "MIDLINE_SAMPLES",
    "NEAR_90",
    "PARTIAL_SPREAD",
    "TIP_OFFSET",
    "AngleUnwrapper",
    "AppliedField",
    "ArmAngles",
    "BodyMotion",
    "Energies",
    "Midline",
    "MidlineProbe",
    "MidlineShape",
    "Observer",
    "PointEvaluator",
    "Strain",
    "StrainProbe",
    "Swimming",
    "arm_angle_points",
    "bending_angle",
    "bending_speed",
    "bonded_length",
    "first_crossing",
    "history_summary",
    "max_over_window",
    "midline_points",
    "midline_samples",
    "midline_shape",
    "summarize_body",
    "summarize_midline",
    "summarize_swimming",
]
