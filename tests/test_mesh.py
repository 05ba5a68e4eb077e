"""Standard mesh and FE-to-standard-mesh mapping."""

import math

import numpy as np
import pytest

from romams_core.mesh import Planform, standard_mesh
from romams_core.structure.mapping import map_to_mesh


def test_standard_mesh_geometry():
    pf = Planform(root_chord=1.0, tip_chord=0.4, semispan=2.0, sweep_le=math.radians(30), n_chord=4, n_span=5)
    mesh = standard_mesh(pf)
    assert mesh.n_nodes == 5 * 6
    g = mesh.grid(mesh.x)
    assert g.shape == (6, 5)
    # root LE at origin, tip LE at semispan * tan(sweep), tip TE at LE + tip chord
    assert g[0, 0] == pytest.approx(0.0)
    assert g[-1, 0] == pytest.approx(2.0 * math.tan(math.radians(30)))
    assert g[-1, -1] - g[-1, 0] == pytest.approx(0.4)
    # panel areas sum to the planform area
    p = mesh.panels
    x, y = mesh.x[p], mesh.y[p]
    area = 0.5 * np.abs(np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1))
    assert area.sum() == pytest.approx(pf.area, rel=1e-12)


@pytest.mark.parametrize("bad", [{"root_chord": -1.0}, {"semispan": float("nan")}, {"n_chord": 0}])
def test_planform_rejects_bad_values_naming_the_field(bad):
    kw = dict(root_chord=1.0, tip_chord=0.5, semispan=1.0) | bad
    with pytest.raises(ValueError, match=next(iter(bad))):
        Planform(**kw)


def test_mapping_reproduces_a_smooth_field():
    pf = Planform(root_chord=1.0, tip_chord=0.5, semispan=1.5, sweep_le=0.4, n_chord=6, n_span=8)
    mesh = standard_mesh(pf)
    rng = np.random.default_rng(0)
    xi, eta = rng.random(400), rng.random(400)
    edge = np.linspace(0, 1, 25)  # FE meshes have nodes on the whole boundary
    xi = np.concatenate([xi, edge, edge, np.zeros(25), np.ones(25)])
    eta = np.concatenate([eta, np.zeros(25), np.ones(25), edge, edge])
    x, y = pf.to_xy(xi, eta)
    f = lambda x, y: (y**2) * (1 + 0.3 * x) - 0.2 * x * y  # noqa: E731
    mapped = map_to_mesh(np.column_stack([x, y]), f(x, y), mesh)
    assert np.max(np.abs(mapped - f(mesh.x, mesh.y))) < 2e-3 * np.max(np.abs(f(mesh.x, mesh.y)))
