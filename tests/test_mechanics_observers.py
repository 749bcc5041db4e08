"""Midline observables (active length, folds, failure indicators) and bending speed.

The pure functions are checked against midlines whose shape is known in
closed form (circular arcs, rigid rotations, a small-deflection cantilever
under a uniform distributed torque); :class:`MidlineProbe` is checked on a
real strip mesh (serially and under ``mpirun -n 2``) with a displacement
field that P2 represents exactly (a rigid rotation about the root).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from magfem.mechanics.observers import (
    ACTIVE_CURVATURE_FRACTION,
    MidlineProbe,
    bending_speed,
    midline_shape,
    summarize_midline,
)

L = 10e-3
N = 81
S = np.linspace(0.0, L, N)
H = L / (N - 1)


def _from_angles(phi_mid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Midline with segment k at tangent angle phi_mid[k] (inextensible, starts at 0)."""
    a = np.concatenate([[0.0], np.cumsum(H * np.cos(phi_mid))])
    w = np.concatenate([[0.0], np.cumsum(H * np.sin(phi_mid))])
    return a, w


def _arc_then_straight(radius: float, ell: float, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact positions: a circular arc of radius R (curving up) over [0, ell], then its tangent."""
    ang = np.minimum(s, ell) / radius
    a = radius * np.sin(ang) + np.maximum(s - ell, 0.0) * np.cos(ell / radius)
    w = radius * (1 - np.cos(ang)) + np.maximum(s - ell, 0.0) * np.sin(ell / radius)
    return a, w


@pytest.mark.parametrize("ell_fraction", [0.25, 0.5, 0.8])
def test_arc_then_straight_active_length_and_one_fold(ell_fraction):
    ell = ell_fraction * L
    radius = ell / math.radians(100)  # the arc turns the tangent by 100 deg
    a, w = _arc_then_straight(radius, ell, S)
    shape = midline_shape(S, a, w, L)
    # curvature is exact on segments inside the arc; the one straddling s = ell is partly bent,
    # so the active length is resolved to one sample spacing
    assert abs(shape.active_length - ell) <= H * (1 + 1e-9)
    assert shape.folds == 1
    w_tip = radius * (1 - math.cos(ell / radius)) + (L - ell) * math.sin(ell / radius)
    assert shape.tip_normal == pytest.approx(abs(w_tip) / L, rel=1e-12)
    assert shape.spread == pytest.approx(np.std(w) / L, rel=1e-12)


@pytest.mark.parametrize("alpha_deg", [0.0, 30.0, 120.0, -75.0, 200.0])
def test_rigid_rotation_has_no_fold_and_no_active_length(alpha_deg):
    alpha = math.radians(alpha_deg)
    a, w = S * math.cos(alpha), S * math.sin(alpha)
    shape = midline_shape(S, a, w, L)
    assert shape.folds == 0
    assert shape.active_length == 0.0
    assert shape.tip_normal == pytest.approx(abs(math.sin(alpha)), abs=1e-12)
    # std of s sin(alpha) over equally spaced s in [0, L]: |sin a| L sqrt((N+1)/(12 (N-1)))
    expected = abs(math.sin(alpha)) * math.sqrt((N + 1) / (12 * (N - 1)))
    assert shape.spread == pytest.approx(expected, abs=1e-12)


def test_s_shape_and_two_creases_are_two_folds():
    # S: +60 deg over the first half, -60 deg over the second (no straight part between)
    k = math.radians(60) / (L / 2)
    s_mid = S[:-1] + H / 2
    phi = np.where(s_mid < L / 2, k * s_mid, k * L - k * s_mid)
    shape = midline_shape(S, *_from_angles(phi), L)
    assert shape.folds == 2
    # two +90 deg creases over [0.1, 0.2] L and [0.6, 0.7] L, straight elsewhere
    k = math.radians(90) / (0.1 * L)
    bend = np.clip(s_mid - 0.1 * L, 0, 0.1 * L) + np.clip(s_mid - 0.6 * L, 0, 0.1 * L)
    shape = midline_shape(S, *_from_angles(k * bend), L)
    assert shape.folds == 2
    # the bent part runs from the first crease's start to the second's end
    assert abs(shape.active_length - 0.6 * L) <= H
    assert abs(shape.active_start - 0.1 * L) <= H
    # a bend below the fold angle (30 deg) is not a fold
    shape = midline_shape(S, *_from_angles(np.radians(30) / L * s_mid), L)
    assert shape.folds == 0


@pytest.mark.parametrize(("a_frac", "b_frac"), [(0.5, 0.6), (0.3, 0.9), (0.75, 0.8)])
def test_bend_away_from_the_root_is_measured_from_where_it_starts(a_frac, b_frac):
    # flat over [0, a], a circular arc turning 90 deg over [a, b], then straight: a long arm
    # lying on the ground that lifts its tip. The bent part is b - a, whatever the flat part;
    # a and b fall on samples, where the curvature is half the arc's (above eta), so the span
    # is exact to rounding
    a_len, b_len = a_frac * L, b_frac * L
    k = math.radians(90) / (b_len - a_len)
    s_mid = S[:-1] + H / 2
    phi = k * np.clip(s_mid - a_len, 0.0, b_len - a_len)
    shape = midline_shape(S, *_from_angles(phi), L)
    assert shape.active_length == pytest.approx(b_len - a_len, abs=1e-9 * L)
    assert shape.active_start == pytest.approx(a_len, abs=1e-9 * L)
    assert shape.folds == 1


def test_slight_kink_at_the_root_does_not_extend_the_bent_part():
    # a bonded edge's kink (the first segment at -0.5 deg: a curvature above eta of the main
    # bend's, over one spacing), flat, then the lift-off bend of 80 deg over [0.6, 0.9] L: the
    # kink turns less than eta times the bend, so only the bend counts
    s_mid = S[:-1] + H / 2

    def bend(a, b, turn_deg):
        return math.radians(turn_deg) * np.clip((s_mid - a) / (b - a), 0.0, 1.0)

    phi = bend(0.6 * L, 0.9 * L, 80.0)
    phi[0] = math.radians(-0.5)
    shape = midline_shape(S, *_from_angles(phi), L)
    assert shape.active_length == pytest.approx(0.3 * L, abs=1e-9 * L)
    assert shape.active_start == pytest.approx(0.6 * L, abs=1e-9 * L)
    # a second bend of -20 deg over [0.1, 0.2] L turns more than eta 80 deg: it counts
    shape = midline_shape(S, *_from_angles(phi + bend(0.1 * L, 0.2 * L, -20.0)), L)
    assert shape.active_length == pytest.approx(0.8 * L, abs=1e-9 * L)
    assert shape.active_start == pytest.approx(0.1 * L, abs=1e-9 * L)


def test_midline_samples_meet_the_requested_spacing():
    from types import SimpleNamespace

    from magfem.mechanics.observers import MIDLINE_SAMPLES, midline_samples

    arms = [SimpleNamespace(length=0.1), SimpleNamespace(length=0.03)]
    assert midline_samples(arms) == MIDLINE_SAMPLES
    assert midline_samples(arms, 0.1e-3) == 1001  # the longest arm: 100 mm / 0.1 mm + 1
    assert midline_samples(arms, 0.3e-3) == 335  # ceil(333.3) + 1: spacing 0.2994 mm
    assert midline_samples(arms, 5e-3) == MIDLINE_SAMPLES  # never fewer than the default
    with pytest.raises(ValueError, match="spacing"):
        midline_samples(arms, -1e-3)


def test_cantilever_under_uniform_torque_active_length():
    # small deflection under a uniform distributed torque m: kappa(s) = m (L - s)/(E I);
    # tangent angle phi(s) = kappa0 (L s - s^2/2), exact central differences of a quadratic
    kappa0 = 0.05 / L**2
    s_mid = S[:-1] + H / 2
    phi = kappa0 * (L * s_mid - s_mid**2 / 2)
    shape = midline_shape(S, *_from_angles(phi), L)
    # |kappa| >= eta max|kappa| <=> L - s >= eta (L - h): s <= L - eta (L - h)
    expected = L - ACTIVE_CURVATURE_FRACTION * (L - H)
    assert expected - H <= shape.active_length <= expected + 1e-12
    assert shape.folds == 0  # the whole arm turns by 0.05/2 rad < 45 deg


def test_field_for_90_degrees_is_read_where_the_angle_crosses():
    from magfem.mechanics.observers import NEAR_90, first_crossing

    # a ramp 0 -> 4 mT along -x, the angle proportional to |B| reaching 89 deg (where the
    # field for 90 deg is read) at 2.7 mT: interpolation in the angle is exact for a value
    # linear in it
    t = np.linspace(0.0, 1.0, 51)
    b = 4e-3 * t
    theta = NEAR_90 * b / 2.7e-3
    history = {"time": t, "angle_arm": theta, "Bx": -b, "By": 0 * b, "Bz": 0 * b}
    out = summarize_midline(history)
    assert out["field_90_arm"] == pytest.approx(2.7e-3, rel=1e-12)
    assert first_crossing(-theta, b, NEAR_90) == pytest.approx(2.7e-3, rel=1e-12)  # either sense
    assert first_crossing(theta, b) == pytest.approx(2.7e-3 * 90 / 89, rel=1e-12)
    history["angle_arm"] = 0.5 * theta  # 66 deg at 4 mT: never
    assert math.isnan(summarize_midline(history)["field_90_arm"])
    assert "field_90_arm" not in summarize_midline({"time": t, "angle_arm": theta})


def test_bending_speed_of_linear_and_sine_rises():
    t = np.linspace(0.0, 0.05, 501)
    omega = math.radians(90) / 0.012  # reaches 90 deg 12 ms after starting at t0 = 10 ms
    theta = np.where(t > 0.01, omega * (t - 0.01), 0.0)
    assert bending_speed(t, theta) == pytest.approx(omega, rel=1e-9)
    # sine: theta = A sin(2 pi f t), 90 deg reached at t90 = asin(90/A)/(2 pi f), from t = 0;
    # linear interpolation of a smooth curve: error O(dt^2 theta''/theta') ~ 1e-4 here
    amp, f = math.radians(150), 20.0
    t = np.linspace(0.0, 0.05, 2001)
    theta = amp * np.sin(2 * math.pi * f * t)
    t90 = math.asin(90 / 150) / (2 * math.pi * f)
    assert bending_speed(t, theta) == pytest.approx(math.radians(90) / t90, rel=1e-3)
    assert math.isnan(bending_speed(t, 0.5 * theta))  # never reaches 90 deg


def test_summary_flags_collapse_and_partial_bending():
    t = np.array([0.0, 1.0, 2.0])
    base = {"time": t, "angle_arm": np.radians([0.0, 50.0, 100.0])}
    quiet = base | {
        "active_length_arm": np.array([0.0, 1e-3, 2e-3]),
        "folds_arm": np.array([0.0, 1.0, 1.0]),
        "tip_normal_arm": np.array([0.0, 0.1, 0.19]),
        "spread_arm": np.array([0.0, 0.05, 0.09]),
    }
    out = summarize_midline(quiet)
    assert out["collapse"] == 0.0 and out["partial_bending"] == 0.0
    assert out["final_active_length_arm"] == 2e-3 and out["max_folds_arm"] == 1.0
    assert out["bending_speed_arm"] == pytest.approx(math.radians(90) / 1.8)
    folded = quiet | {"folds_arm": np.array([0.0, 2.0, 1.0])}
    assert summarize_midline(folded)["collapse"] == 1.0
    # an arm lifted whole (|w_tip|/L = sin 60 deg, spread 0.29 sin 60 deg) has not collapsed
    lifted = quiet | {"tip_normal_arm": np.array([0.0, 0.87, 0.5])}
    assert summarize_midline(lifted)["collapse"] == 0.0
    spread = quiet | {"spread_arm": np.array([0.0, 0.2, 0.0])}
    assert summarize_midline(spread)["partial_bending"] == 1.0
    assert "max_tip_lateral_arm" not in out  # a strip's history has no sideways column
    side = quiet | {"tip_lateral_arm": np.array([0.0, 0.4, 0.1])}
    assert summarize_midline(side)["max_tip_lateral_arm"] == 0.4
    assert summarize_midline(side)["collapse"] == 1.0  # fell over sideways
    assert summarize_midline(side)["first_sideways_arm"] == 1.0  # the first sample past 0.2
    upright = summarize_midline(quiet | {"tip_lateral_arm": np.full(3, 0.19)})
    assert upright["collapse"] == 0.0 and math.isnan(upright["first_sideways_arm"])
    assert "first_sideways_arm" not in out


def test_summary_failure_indicators_over_the_first_half_period():
    """The lift (first half period of a 0.25 Hz drive from t = 0: t <= 2 s) keeps one fold and
    no sideways motion; a second fold after the reversal trips the whole run's flag only."""
    t = np.arange(7.0)
    history = {
        "time": t,
        "angle_arm": np.radians([0.0, 60.0, 120.0, 90.0, -30.0, 200.0, 250.0]),
        "active_length_arm": np.full(7, 1e-3),
        "folds_arm": np.array([0.0, 1.0, 1.0, 1.0, 2.0, 3.0, 3.0]),
        "tip_normal_arm": np.array([0.0, 0.8, 0.9, 0.9, 0.3, 0.5, 0.5]),
        "spread_arm": np.array([0.0, 0.2, 0.25, 0.25, 0.1, 0.2, 0.2]),
        "tip_lateral_arm": np.array([0.0, 0.0, 0.01, 0.05, 0.3, 0.1, 0.1]),
    }
    out = summarize_midline(history, start=0.0, frequency=0.25)
    assert out["max_folds_halfperiod_arm"] == 1.0 and out["max_folds_arm"] == 3.0
    assert out["max_tip_lateral_halfperiod_arm"] == 0.01 and out["max_tip_lateral_arm"] == 0.3
    assert out["collapse_halfperiod"] == 0.0 and out["collapse"] == 1.0
    assert out["partial_bending_halfperiod"] == 1.0
    late = summarize_midline(history, start=5.0, frequency=0.25)  # window ends after the run
    assert math.isnan(late["max_folds_halfperiod_arm"]) and math.isnan(late["collapse_halfperiod"])
    assert "collapse_halfperiod" not in summarize_midline(history)  # no drive: no window


def test_midline_probe_on_a_strip_rigid_rotation(repo, comm):
    """P2 holds a rigid rotation exactly: no fold, no active length, tip_normal = |sin a|."""
    from dolfinx import fem

    from magfem.case import load_case
    from magfem.geometry.robot_mesh import create_robot_mesh

    case = load_case(repo / "cases" / "active_length.toml", ["mesh.size=1mm", "mesh.layers=1"])
    robot = create_robot_mesh(case.robot, case.mesh, comm)
    V = fem.functionspace(robot.mesh, ("Lagrange", 2, (2,)))
    arm = robot.arms[0]
    root = np.asarray(arm.root)[:2]
    alpha = math.radians(70)
    rot = np.array([[math.cos(alpha), -math.sin(alpha)], [math.sin(alpha), math.cos(alpha)]])
    if arm.direction[0] < 0:
        rot = rot.T  # an arm pointing to -x lifts by turning the other way

    def rotation(x):
        d = x[:2] - root[:, None]
        return rot @ d - d

    u = fem.Function(V)
    u.interpolate(rotation)
    probe = MidlineProbe(V, robot.arms)
    row = probe(u)
    name = arm.name
    assert row[f"folds_{name}"] == 0.0
    assert row[f"active_length_{name}"] == 0.0
    assert row[f"tip_normal_{name}"] == pytest.approx(math.sin(alpha) * (1 - 1e-9), rel=1e-9)
    assert set(probe.columns()) == set(row)


@pytest.mark.slow  # over 0.3 s: not in the fast tier
def test_run_writes_a_motion_gif(repo, shared_tmp, comm):
    """A tiny two-arm run (3 ms, 0.5 ms steps) animates: > 1 frame, and the arm moves."""
    from PIL import Image, ImageSequence

    from magfem.cli import main

    out = shared_tmp / "gif"
    args = ["mesh.size=0.5mm", "mesh.layers=1", "time.end=3ms", "time.step=0.5ms"]
    args += ["contact.ground=false", "output.vtx_every=0", "output.plot=false"]
    args += ["output.animation=true"]
    sets = [a for item in args for a in ("--set", item)]
    assert (
        main(["run", str(repo / "cases" / "two_arm_20hz.toml"), "--out", str(out), *sets, "-q"])
        == 0
    )
    comm.barrier()
    gif = out / "motion.gif"
    assert gif.is_file()
    assert not (out / "snapshots").exists()  # removed once the GIF is written
    with Image.open(gif) as im:
        frames = [np.asarray(f.convert("L"), dtype=float) for f in ImageSequence.Iterator(im)]
    assert len(frames) > 1
    # below the corner label (top 60 of 320 rows: 3 text lines) only the body changes; the arm
    # lifts in 3 ms, so the last frame differs from the first (flat) one there: measured 0.72 %
    # of those pixels (7 frames, 2026-11-21); identical frames would give 0
    body = [f[60:] for f in frames]
    changed = np.mean(np.abs(body[-1] - body[0]) > 10)
    assert changed > 1e-3


def test_midline_probe_reads_a_sideways_turn_as_tip_lateral(repo, comm):
    """A 3D arm turned rigidly by 30° about the vertical through its root (in the resting
    plane, as an arm that falls over sideways ends): its tip moves sideways by sin 30° of its
    length and not out of the plane; P2 holds the rotation exactly."""
    from dolfinx import fem

    from magfem.case import load_case
    from magfem.geometry.robot_mesh import create_robot_mesh

    sets = ["mesh.size=2mm", "mesh.size_across=2mm", "mesh.layers=1"]
    case = load_case(repo / "cases" / "one_arm_shapes_triangle.toml", sets)
    robot = create_robot_mesh(case.robot, case.mesh, comm)
    assert robot.mesh.geometry.dim == 3
    V = fem.functionspace(robot.mesh, ("Lagrange", 2, (3,)))
    arm = robot.arms[0]
    root = np.asarray(arm.root, dtype=float)
    alpha = math.radians(30)
    rot = np.array(
        [[math.cos(alpha), -math.sin(alpha), 0], [math.sin(alpha), math.cos(alpha), 0], [0, 0, 1]]
    )

    def yaw(x):
        d = x - root[:, None]
        return rot @ d - d

    u = fem.Function(V)
    u.interpolate(yaw)
    probe = MidlineProbe(V, robot.arms)
    row = probe(u)
    assert row[f"tip_lateral_{arm.name}"] == pytest.approx(math.sin(alpha) * (1 - 1e-9), rel=1e-9)
    assert row[f"tip_normal_{arm.name}"] == pytest.approx(0.0, abs=1e-12)
    assert row[f"folds_{arm.name}"] == 0.0
    assert set(probe.columns()) == set(row)


@pytest.mark.parametrize(
    ("case_name", "expected"),
    [("active_length.toml", 1e-3), ("two_arm_20hz.toml", 0.5e-3), ("five_arm.toml", 0.0)],
)
def test_bonded_length_is_the_clamp_under_each_arm(repo, comm, case_name, expected):
    """The bonded strip under an arm: 1 mm root strip, half of a two-arm's 1 mm middle
    patch per arm, nothing under a five-arm star's arms (its hub is bonded)."""
    from magfem.case import load_case
    from magfem.geometry.robot_mesh import create_robot_mesh
    from magfem.geometry.robots import outline_of
    from magfem.mechanics.observers import bonded_length

    case = load_case(repo / "cases" / case_name, ["mesh.size=1.5mm", "mesh.layers=1"])
    robot = create_robot_mesh(case.robot, case.mesh, comm)
    gdim = robot.mesh.geometry.dim
    px, py, pz = case.robot.position
    offset = (px, py) if gdim == 3 else (px, pz)
    for arm in robot.arms:
        # in_clamp has a relative tolerance 1e-6 of the robot's size at the patch edge
        got = bonded_length(arm, outline_of(case.robot).in_clamp, offset, gdim)
        assert got == pytest.approx(expected, abs=1e-7)


def test_midline_probe_active_length_starts_at_the_bonded_edge(repo, comm):
    """A strip bent into a circular arc from the clamp edge s_b = 1 mm over ℓ = 4 mm, then
    straight: the active length is ℓ (not s_b + ℓ), to one sample spacing h = 0.125 mm
    (the arc's ends fall on samples here; measured 3.999999 mm), and the largest
    curvature is 1/R. The bend's start is found from the curvature, so the probe reads ℓ
    with or without the patch; the patch clips a bend that reaches into it."""
    from dolfinx import fem

    from magfem.case import load_case
    from magfem.geometry.robot_mesh import create_robot_mesh
    from magfem.geometry.robots import outline_of
    from magfem.mechanics.observers import bonded_length

    sets = ["robot.length=10mm", "mesh.size=0.25mm", "mesh.layers=1"]
    case = load_case(repo / "cases" / "active_length.toml", sets)
    robot = create_robot_mesh(case.robot, case.mesh, comm)
    arm = robot.arms[0]
    root = np.asarray(arm.root)[:2]
    sign = 1.0 if arm.direction[0] > 0 else -1.0
    px, _, pz = case.robot.position
    s_b = bonded_length(arm, outline_of(case.robot).in_clamp, (px, pz), 2)
    ell, radius = 4e-3, 5e-3

    def bend(x):
        s = sign * (x[0] - root[0])  # along the arm from its root
        z = x[1] - root[1]  # offset from the mid-thickness line
        sb = np.clip(s - s_b, 0.0, None)
        ang = np.minimum(sb, ell) / radius
        # point of the bent midline and its normal (−sin, cos) in the arm's side frame
        a = np.where(s < s_b, s, s_b + radius * np.sin(ang) + np.maximum(sb - ell, 0) * np.cos(ang))
        w = radius * (1 - np.cos(ang)) + np.maximum(sb - ell, 0.0) * np.sin(ang)
        xa = a - z * np.sin(ang)
        xw = w + z * np.cos(ang)
        return np.vstack([root[0] + sign * xa - x[0], root[1] + xw - x[1]])

    V = fem.functionspace(robot.mesh, ("Lagrange", 2, (2,)))
    u = fem.Function(V)
    u.interpolate(bend)
    h = arm.length / 80
    with_patch = MidlineProbe(V, robot.arms, bonded={arm.name: s_b})(u)
    from_root = MidlineProbe(V, robot.arms)(u)
    name = f"active_length_{arm.name}"
    assert with_patch[name] == pytest.approx(ell, abs=h)
    # s_b carries in_clamp's tolerance (1e-6 of the robot's size, 1e-8 m here)
    assert from_root[name] == pytest.approx(with_patch[name], abs=1e-8)
    inside = MidlineProbe(V, robot.arms, bonded={arm.name: s_b + 1e-3})(u)
    assert with_patch[name] - inside[name] == pytest.approx(1e-3, abs=1e-12)
    # the sharpest bend is the arc's 1/R: the segment-angle difference is exact for sample
    # points on an arc, and the P2 interpolant of the map passes through them to 1e-11
    # (measured); 1e-3 leaves room for a coarser interpolant, not for a wrong formula
    assert with_patch[f"curvature_{arm.name}"] == pytest.approx(1 / radius, rel=1e-3)
