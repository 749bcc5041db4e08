"""Pictures: the robot inside its field sources is drawn where it should be."""

from __future__ import annotations

import numpy as np

from magfem.plot import _scene_case, plot_scene, source_grids


def test_source_grids_place_the_coil_windings():
    case = _scene_case()
    items = source_grids(case.field.sources)
    assert len(items) == 2  # two windings, uniform sources have no body
    spec = case.field.sources[0]
    for item, sign in zip(items, (-1, 1), strict=True):
        b = item.grid.bounds  # (xmin, xmax, ymin, ymax, zmin, zmax); axis is x
        centre_x = 0.5 * (b[0] + b[1])
        assert np.isclose(centre_x, sign * spec.separation / 2, atol=1e-9)
        assert np.isclose(b[1] - b[0], spec.length, rtol=1e-9)
        assert np.isclose(b[3], spec.outer_radius, rtol=1e-2)  # polygonal circle


def test_plot_scene_writes_png(shared_tmp, comm):
    path = plot_scene(_scene_case(), shared_tmp / "scene.png", comm=comm)
    if comm.rank == 0:
        import matplotlib.image

        img = matplotlib.image.imread(path)
        assert img.shape[:2] == (600, 800)
        # the robot (red) is drawn at the centre of the picture
        centre = img[250:350, 350:450, :3]
        reddish = (centre[..., 0] > 0.6) & (centre[..., 1] < 0.45) & (centre[..., 2] < 0.45)
        assert reddish.any()
    else:
        assert path is None
