"""``[robot]`` and ``[mesh]`` tables: the shape registry, validation, the flat round trip.

References: the case files of ``cases/`` (every one must parse and write
back to an equal case), and the keys each shape class declares.
"""

from __future__ import annotations

import dataclasses
import pickle

import pytest
from mpi4py import MPI

from magfem.case import load_case, parse_case
from magfem.config import CaseError, from_table, to_table
from magfem.geometry.outline import Outline
from magfem.geometry.robot_mesh import create_robot_mesh
from magfem.geometry.shapes import SHAPES, Shape
from magfem.geometry.shapes.base import register
from magfem.geometry.spec import STRIP_SHAPES, MeshSpec, RobotSpec, check_mesh_for_robot

THICKNESS = 1e-4


def robot(shape: str, **keys: object) -> RobotSpec:
    return from_table(RobotSpec, {"shape": shape, "thickness": THICKNESS, **keys}, "robot")


def meshspec(**keys: object) -> MeshSpec:
    return from_table(MeshSpec, keys, "mesh")


@pytest.mark.parametrize("shape", list(SHAPES))
def test_every_shape_declares_documented_keys_with_defaults(shape):
    """A registered shape: its name, keys with a doc and a default, an outline of positive area."""
    cls = SHAPES[shape]
    assert issubclass(cls, Shape) and cls.name == shape
    for f in dataclasses.fields(cls):
        assert f.metadata.get("doc"), (shape, f.name)
        assert f.default is not dataclasses.MISSING, (shape, f.name)
        assert f.name not in ("shape", "thickness", "position", "params"), f.name
    params = cls()
    outline = params.outline()
    assert isinstance(outline, Outline)
    assert outline.area > 0 and params.min_feature > 0
    assert len({a.name for a in outline.arms}) == len(outline.arms)


@pytest.mark.parametrize("shape", list(SHAPES))
def test_flat_table_round_trip(shape):
    """to_table writes the flat [robot] table: common keys + the shape's keys, no ``params``."""
    r = robot(shape)
    table = to_table(r)
    own = {f.name for f in dataclasses.fields(SHAPES[shape])}
    assert (
        {"shape", "thickness", "position"} <= set(table) <= {"shape", "thickness", "position"} | own
    )
    assert all(not isinstance(v, dict) for v in table.values())
    assert from_table(RobotSpec, table, "robot") == r


def test_every_case_file_round_trips(repo):
    """Every case of cases/ parses unchanged and its resolved table parses to the same case."""
    paths = [p for p in sorted((repo / "cases").glob("*.toml")) if "[robot]" in p.read_text()]
    assert paths
    for path in paths:
        case = load_case(path)
        assert parse_case(to_table(case)) == case, path.name


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ({"shape": "hexagon"}, "robot.shape"),
        ({"shape": "rectangle", "arms": 4}, "robot.arms"),  # a key of another shape
        ({"shape": "rectangle", "clamp_length": "20 mm"}, "robot.clamp_length"),
        ({"shape": "trapezoid", "tip_width": "-1 mm"}, "robot.tip_width"),
        ({"shape": "star", "arms": 7}, "robot.arms"),
        ({"shape": "star", "hub_radius": "0.5 mm"}, "robot.hub_radius"),
        ({"shape": "star", "clamp_radius": "3 mm"}, "robot.clamp_radius"),
        ({"shape": "flower", "petals": 2}, "robot.petals"),
        ({"shape": "flower", "centre_diameter": "3 mm"}, "robot.centre_diameter"),
        ({"shape": "failure_triangle", "type": "IV"}, "robot.type"),
        ({"shape": "manta", "wingspan": "3 mm"}, "robot.wingspan"),
        ({"shape": "membrane", "thickness": "10 mm"}, "robot.thickness"),
        ({"shape": "membrane", "params": {}}, "robot.params"),
    ],
)
def test_bad_robot_names_key(table, key):
    table = {"thickness": THICKNESS, **table}
    with pytest.raises(CaseError) as err:
        from_table(RobotSpec, table, "robot")
    assert err.value.key == key
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("shape", "keys", "problem"),
    [
        ("rectangle", {"clamp_length": "10 mm"}, "must be < length (0.01 m)"),
        ("bow_tie", {"clamp_length": "10 mm"}, "must be < length (0.01 m)"),
        ("disk", {"clamp_diameter": "10 mm"}, "must be < diameter (0.01 m)"),
        ("failure_triangle", {"clamp_length": "8 mm"}, "must be < the type I length (0.008 m)"),
        ("manta", {"wingspan": "4 mm"}, "must be > body_width (0.004 m)"),
        ("star", {"arm_length": "2.25 mm"}, "must be > hub_radius + arm_tip_width/2 (0.00225 m)"),
        ("star", {"clamp_radius": "1.5 mm"}, None),  # equal to the hub radius: allowed
        ("flower", {"clamp_diameter": "12 mm"}, None),  # the whole centre disk bonded
        ("manta", {"fin_tip_width": "10 mm"}, None),  # a fin as long as the body at its tip
    ],
)
def test_cross_key_limits_at_the_boundary(shape, keys, problem):
    """Strict limits refuse the equal value, inclusive ones accept it; the message gives it."""
    if problem is None:
        robot(shape, **keys)
        return
    with pytest.raises(CaseError) as err:
        robot(shape, **keys)
    assert problem in str(err.value)


def test_unknown_key_lists_the_keys_of_the_shape():
    with pytest.raises(CaseError) as err:
        robot("triangle", width="1 mm")
    assert err.value.key == "robot.width"
    assert "clamp_length, length, position, root_width, shape, thickness" in str(err.value)


def test_shape_keys_read_through_the_spec():
    """``robot.width`` reads the shape's key (as before the registry); other shapes have none."""
    r = robot("membrane", width="3 mm")
    assert r.width == r.params.width == pytest.approx(3e-3)
    assert r.uniform_width == pytest.approx(3e-3)
    star = robot("star")
    assert getattr(star, "width", None) is None and star.uniform_width is None
    with pytest.raises(AttributeError, match="shape 'star' has no key 'width'"):
        star.width  # noqa: B018
    assert robot("failure_triangle", type="II").length == pytest.approx(16e-3)
    assert pickle.loads(pickle.dumps(r)) == r  # the fall-through must not break pickling


def test_strip_shapes_are_the_uniform_width_ones():
    assert set(STRIP_SHAPES) == {"rectangle", "two_arm_rectangle", "membrane"}
    for shape in SHAPES:
        width = robot(shape).uniform_width
        assert (width is not None) == (shape in STRIP_SHAPES)
        if width is not None:
            assert width == robot(shape).params.width


def test_spec_built_in_code_is_checked():
    params = SHAPES["rectangle"]()
    r = RobotSpec(shape="rectangle", thickness=THICKNESS, params=params)
    assert r == robot("rectangle")
    with pytest.raises(TypeError, match="StarShape"):
        RobotSpec(shape="star", thickness=THICKNESS, params=params)


def test_mesh_spec_checks():
    assert meshspec(size="0.1 mm") == MeshSpec(size=1e-4)  # only size is required
    with pytest.raises(CaseError, match="tip_size"):
        meshspec(size="0.1 mm", tip_size="0.2 mm")
    with pytest.raises(CaseError, match="root_size") as err:
        meshspec(size="0.1 mm", root_size="0.2 mm")
    assert "<= size" in str(err.value)
    with pytest.raises(CaseError, match="uniformly") as err:
        meshspec(size="0.1 mm", root_size="0.05 mm", model="rod")
    assert err.value.key == "mesh.root_size"
    free = robot("star", clamp_radius=0)
    with pytest.raises(CaseError, match="has none") as err:
        check_mesh_for_robot(free, meshspec(size="0.5 mm", root_size="0.1 mm", model="surface"))
    assert err.value.key == "mesh.root_size"
    check_mesh_for_robot(robot("rectangle"), meshspec(size="0.5 mm", root_size="0.1 mm"))
    with pytest.raises(CaseError, match="element"):
        meshspec(size="0.1 mm", element="wedge")  # prism solids: no facet tags in dolfinx 0.11
    with pytest.raises(CaseError) as err:
        create_robot_mesh(robot("star"), meshspec(size=1e-4, model="strip"), MPI.COMM_WORLD)
    assert err.value.key == "mesh.model"
    with pytest.raises(CaseError) as err:
        create_robot_mesh(robot("rectangle"), meshspec(size="3 mm"), MPI.COMM_WORLD)
    assert err.value.key == "mesh.size"


def test_a_shape_without_a_smallest_feature_is_refused_at_registration():
    class Bare(Shape):
        def outline(self):  # pragma: no cover - never built
            raise AssertionError

    with pytest.raises(TypeError, match="neither feature_keys nor min_feature"):
        register("bare_test_shape")(Bare)
    assert "bare_test_shape" not in SHAPES
