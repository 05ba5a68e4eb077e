"""The UVLM's root symmetry (symmetric, antisymmetric, none = a free wing): the image rings and wake are exactly an
explicitly mirrored lattice, a free wing equals the mirrored half wing of half its span, an antisymmetric loading
lifts less, and the service trains the uvlm with the wing's symmetry."""

import dataclasses
import math

import numpy as np
import pytest

from romams_core.aero import dlm, uvlm
from romams_core.aero.uvlm import UvlmSolver, build_uvlm, frequency_response
from romams_core.errors import InputError
from romams_core.mesh import Planform, StandardMesh, standard_mesh
from romams_core.wing import template

SIGNS = {"symmetric": 1.0, "antisymmetric": -1.0, "none": 0.0}


def _rect(semispan: float, nc: int, ns: int) -> StandardMesh:
    """Flat rectangular wing of unit chord from y = 0 to ``semispan`` (m), nc x ns panels."""
    return standard_mesh(Planform(root_chord=1.0, tip_chord=1.0, semispan=semispan, n_chord=nc, n_span=ns))


def _full_span_expected(mesh: StandardMesh, system: uvlm.UvlmSystem, tip_inset: bool,
                        sign: float) -> tuple[np.ndarray, np.ndarray]:
    """Bound [K, K] and wake [K, n_wake, ns] AICs from the half wing's ring grid mirrored explicitly to y < 0 (one
    full-span corner grid, no image), the mirrored rings' columns added with ``sign`` (0: dropped)."""
    nc, ns, beta = mesh.n_chord, mesh.n_span, system.beta
    _, _, xr, yl = uvlm._ring_grid(mesh, tip_inset, free_root=False)
    assert yl[0] == 0.0  # the root edge is on the mirror plane
    x_full = np.hstack([xr[:, :0:-1], xr])  # columns -ns .. -1 (mirrored), 0 (root), 1 .. ns
    y_full = np.concatenate([-yl[:0:-1], yl])
    px, py = system.colloc_xy[:, 0] / mesh.c_ref / beta, system.colloc_xy[:, 1] / mesh.c_ref

    def fold(full: np.ndarray) -> np.ndarray:
        """Right rings (b = ns + j) plus sign times their mirrors (b = ns - 1 - j)."""
        return full[:, :, ns:] + sign * full[:, :, ns - 1 :: -1]

    bound = fold(uvlm._ring_influence(px, py, x_full / beta, y_full, image_sign=0.0))
    xw = x_full[-1][None, :] + system.dt_star * np.arange(system.n_wake + 1)[:, None]
    wake = fold(uvlm._ring_influence(px, py, xw / beta, y_full, image_sign=0.0))
    return bound.transpose(0, 2, 1).reshape(nc * ns, nc * ns), wake


@pytest.mark.parametrize("symmetry, tip_inset", [("symmetric", False), ("symmetric", True), ("antisymmetric", False),
                                                  ("antisymmetric", True), ("none", False)])
def test_image_equals_an_explicitly_mirrored_lattice(symmetry, tip_inset):
    """Bound and wake AICs of each symmetry = the full-span lattice's with mirrored columns +, - or dropped,
    within 1e-12 of the largest entry (measured 0 .. 4e-16), on a swept tapered wing at M 0.5. (A free wing with
    the tip inset has its root edge inset too, so its grid is not the mirror's: the free-wing test covers it.)"""
    pf = Planform(root_chord=1.0, tip_chord=0.5, semispan=1.2, sweep_le=math.radians(30.0), n_chord=3, n_span=4)
    mesh = standard_mesh(pf)
    system = build_uvlm(mesh, 0.5, 1.0 / 3, wake_chords=2.0, tip_inset=tip_inset, symmetry=symmetry)
    assert system.image_sign == SIGNS[symmetry]
    bound, wake = _full_span_expected(mesh, system, tip_inset, SIGNS[symmetry])
    assert np.abs(system.aic - bound).max() <= 1e-12 * np.abs(bound).max()
    assert np.abs(system.aic_wake - wake).max() <= 1e-12 * np.abs(wake).max()
    if symmetry != "symmetric":  # and it is not the symmetric answer
        sym = build_uvlm(mesh, 0.5, 1.0 / 3, wake_chords=2.0, tip_inset=tip_inset)
        assert np.abs(sym.aic - system.aic).max() > 1e-3 * np.abs(sym.aic).max()


@pytest.mark.parametrize("tip_inset", [True, False])
def test_free_wing_equals_the_mirrored_half_wing_of_half_its_span(tip_inset):
    """A free rectangular wing on 0 <= y <= b is the full wing that a symmetric half wing of semispan b/2 mirrors
    (n_span doubled, so the lattices coincide; with the tip inset the free root edge is inset too): its heave and
    pitch GAC (steady and k = 0.5) are twice the half wing's, within 1e-9 relative (measured 1e-15)."""
    b = 3.0
    half, free = _rect(b / 2, 4, 4), _rect(b, 4, 8)

    def gac(mesh: StandardMesh, symmetry: str) -> np.ndarray:
        shapes = np.column_stack([np.ones(mesh.n_nodes), -mesh.x])  # heave, pitch about the LE (h = -alpha x)
        system = build_uvlm(mesh, 0.0, 0.25, wake_chords=5.0, tip_inset=tip_inset, symmetry=symmetry)
        return frequency_response(mesh, shapes, 0.0, [0.0, 0.5], system=system)

    h_half, h_free = gac(half, "symmetric"), gac(free, "none")
    assert np.abs(h_free - 2.0 * h_half).max() <= 1e-9 * np.abs(h_free).max()
    cl_alpha = h_free[0, 0, 1].real / free.planform.area  # 3.08 (inset) / 3.40 /rad; Helmbold AR 3: 3.36
    assert 2.5 < cl_alpha < 3.6


def test_free_wing_time_march_equals_the_mirrored_half_wing():
    """The same through UvlmSolver.simulate (default lattice refinement 2, sub-steps): a random heave/pitch march
    on the free wing gives twice the half wing's GAC within 1e-9 relative (measured 3e-16), at M 0.3."""
    b = 3.0
    half, free = _rect(b / 2, 3, 3), _rect(b, 3, 6)
    sig = 0.01 * np.random.default_rng(0).standard_normal((40, 2))

    def gac(mesh: StandardMesh, symmetry: str) -> np.ndarray:
        shapes = np.column_stack([np.ones(mesh.n_nodes), -mesh.x])
        return UvlmSolver(wake_chords=3.0, symmetry=symmetry).simulate(mesh, shapes, sig, 0.3, 1.0 / 3)

    g_half, g_free = gac(half, "symmetric"), gac(free, "none")
    assert np.abs(g_free - 2.0 * g_half).max() <= 1e-9 * np.abs(g_free).max()


def test_antisymmetric_loading_lifts_less_than_symmetric():
    """Sanity on an AR-3 (full span) rectangular half wing at M 0: with the image's loading reversed (a rolling
    wing) the root sheds a strong trailing vortex, so the steady lift per unit incidence, and the lift of a roll
    shape h = y at k = 0.3, fall below the symmetric case's; the free half wing lies between (measured lift per
    unit incidence 4.68, 2.97, 2.64 m^2 and roll-shape lift 1.74, 1.40, 1.29 m^2 for symmetric, none,
    antisymmetric)."""
    mesh = _rect(1.5, 4, 6)
    shapes = np.column_stack([np.ones(mesh.n_nodes), -mesh.x, mesh.y])  # heave (lift), incidence, roll
    h = {s: frequency_response(mesh, shapes, 0.0, [0.0, 0.3], wake_chords=10.0, symmetry=s) for s in SIGNS}
    lift = {s: h[s][0, 0, 1].real for s in SIGNS}
    roll = {s: abs(h[s][1, 0, 2]) for s in SIGNS}
    assert lift["antisymmetric"] < lift["none"] < lift["symmetric"]
    assert lift["antisymmetric"] < 0.7 * lift["symmetric"]
    assert roll["antisymmetric"] < 0.9 * roll["symmetric"]
    assert UvlmSolver(symmetry="antisymmetric").info(0.3).description.endswith(
        "root antisymmetric (mirror-image rings and wake of the opposite strength)")
    with pytest.raises(InputError) as e:
        build_uvlm(mesh, 0.3, 0.25, symmetry="mirrored")
    assert e.value.field == "symmetry"


def test_service_trains_the_uvlm_with_the_wings_symmetry(monkeypatch):
    """rom_identity puts a non-symmetric wing's symmetry into a uvlm ROM's options (a symmetric wing's identity is
    unchanged), the training builds the lattice with it and the DLM damping cross-check uses the same; a bad
    symmetry option is refused before queueing."""
    from romams.services.errors import InvalidInput
    from romams.services.training import allowed_options, check_options, rom_identity, train

    wing = dataclasses.replace(template("cropped-delta"), symmetry="antisymmetric")
    ident = rom_identity("uvlm", 4, 4, {"n_steps": 300}, wing=wing)
    assert ident == {"solver": "uvlm", "na": 4, "nb": 4, "options": {"n_steps": 300, "symmetry": "antisymmetric"}}
    assert rom_identity("uvlm", wing=template("cropped-delta")) == {"solver": "uvlm", "na": 8, "nb": 8,
                                                                     "options": {}}
    assert "symmetry" in allowed_options("uvlm")
    with pytest.raises(InvalidInput) as e:
        check_options("uvlm", {"symmetry": "mirrored"})
    assert e.value.field == "options.symmetry"

    seen: list[tuple[str, str]] = []
    build, gaf = UvlmSolver.build, dlm.DlmSolver.gaf
    monkeypatch.setattr(UvlmSolver, "build", lambda self, *a: seen.append(("uvlm", self.symmetry)) or build(self, *a))
    monkeypatch.setattr(dlm.DlmSolver, "gaf",
                        lambda self, *a, **k: seen.append(("dlm", self.symmetry)) or gaf(self, *a, **k))
    mesh = standard_mesh(dataclasses.replace(wing.planform, n_chord=3, n_span=3))
    shapes = 0.01 * (mesh.y / wing.planform.semispan)[:, None] ** 2
    rom = train(mesh, shapes, 0.3, ident)
    assert rom.validation_nrmse.max() < 0.02
    assert seen == [("uvlm", "antisymmetric"), ("dlm", "antisymmetric")]
