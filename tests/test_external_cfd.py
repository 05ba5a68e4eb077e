"""External CFD in the time domain (romams.services.external_cfd, romams_core.external_cfd): the built-in UVLM run
as if it were external, through the package files and the GAC upload, gives the ROM of a direct training; malformed
uploads name the field and store nothing."""

import io
import json
import zipfile

import numpy as np
import pytest

from romams.persistence import open_store
from romams.services.errors import InvalidInput
from romams.services.external_cfd import export_package, import_gac, parse_gac
from romams_core.aero.uvlm import UvlmSolver
from romams_core.basis import build_basis, project
from romams_core.flutter import flutter_analysis
from romams_core.mesh import standard_mesh
from romams_core.statespace import to_modal
from romams_core.structure.modal import modal_analysis
from romams_core.training import train_rom
from romams_core.wing import template

MACH = 0.5
ORDERS = {"na": 6, "nb": 6}


@pytest.fixture()
def case(data_dir):
    """A store with the cropped delta and a basis of its 3 baseline modes; the package at M 0.5."""
    wing = template("cropped-delta")
    mesh = standard_mesh(wing.planform)
    modal = modal_analysis(wing, None, 3, mesh)
    basis = build_basis(modal.shapes, n_modes=3, mac_threshold=0.9999)
    store = open_store()
    wid = store.wings.ensure(wing)
    bid = store.bases.save(wid, basis, {"samples": 1, "modes": 3})
    package, settings = export_package(wing, bid, basis, MACH, ORDERS)
    return wing, mesh, modal, basis, store, wid, bid, package, settings


def test_package_run_by_the_uvlm_gives_the_directly_trained_rom(case):
    wing, mesh, modal, basis, store, wid, bid, package, settings = case
    with zipfile.ZipFile(io.BytesIO(package)) as z:
        assert set(z.namelist()) == {"excitation.npz", "excitation.csv", "shapes.csv", "settings.json", "README.md"}
        arrays = np.load(io.BytesIO(z.read("excitation.npz")))
        from_csv = np.loadtxt(io.StringIO(z.read("excitation.csv").decode()), delimiter=",", skiprows=1)
        sent = json.loads(z.read("settings.json"))
        assert "dp positive up" in z.read("README.md").decode()
    signals = arrays["signals"]
    np.testing.assert_array_equal(from_csv[:, 2:], signals)  # the text carries every digit
    np.testing.assert_array_equal(arrays["shapes"], basis.shapes)
    assert signals.shape == (2 * sent["n_steps"], basis.n_basis) and sent["mach"] == MACH
    # "the CFD engineer's run": the UVLM on the package's signals, written back as CSV
    uvlm = UvlmSolver(refine=1)
    gac = uvlm.simulate(mesh, arrays["shapes"], signals, MACH, float(arrays["dt_star"]))
    text = "g_0,g_1,g_2\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in gac)
    rid, rom = import_gac(store, wid, wing, bid, basis, MACH, parse_gac(text.encode(), "gac.csv"), "uvlm-copy",
                          sent)
    direct = train_rom(mesh, basis.shapes, MACH, uvlm, **ORDERS)
    assert rom.solver == "external:uvlm-copy" and store.roms.load(rid).solver == "external:uvlm-copy"
    np.testing.assert_allclose(rom.validation_nrmse, direct.validation_nrmse, rtol=1e-9)
    gamma = project(basis.shapes, modal.shapes).gamma  # the basis spans the structure's own modes
    a, b = (flutter_analysis(modal.omega, to_modal(r.ss, gamma), r.c_ref, MACH, zeta=wing.modal_damping)
            for r in (rom, direct))
    assert a.flutter_found and a.flutter_mode == b.flutter_mode
    assert a.v_flutter_m_s == pytest.approx(b.v_flutter_m_s, rel=1e-9)  # the issue asks 1e-9


def test_malformed_gac_uploads_name_the_field_and_store_nothing(case):
    wing, mesh, modal, basis, store, wid, bid, package, settings = case
    n = 2 * settings["n_steps"]
    good = np.random.default_rng(0).standard_normal((n, 3))  # right size, nonsense values
    nan = good.copy()
    nan[5, 1] = np.nan
    before = store.roms.of_wing(wid)
    for gac, opts, field in ((good[:-1], settings, "gac"),  # one sample short
                             (good[:, :2], settings, "gac"),  # a shape missing
                             (nan, settings, "gac"),
                             (good, {**settings, "n_steps": settings["n_steps"] + 2}, "gac"),  # other settings
                             (good, {**settings, "colour": 1}, "options.colour"),
                             (good, {**settings, "mach": 0.7}, "mach")):
        with pytest.raises(InvalidInput) as e:
            import_gac(store, wid, wing, bid, basis, MACH, gac, "bad", opts)
        assert e.value.field == field, (field, e.value)
    with pytest.raises(InvalidInput) as e:
        import_gac(store, wid, wing, bid, basis, MACH, good, "no spaces", settings)
    assert e.value.field == "label"
    with pytest.raises(InvalidInput) as e:  # all-zero forces: no response to identify
        import_gac(store, wid, wing, bid, basis, MACH, np.zeros((n, 3)), "zeros", settings)
    assert e.value.field == "gac"
    for data, field in ((b"PK\x03\x04junk", "file"), (b"g_0\nx\n", "file")):
        with pytest.raises(InvalidInput) as e:
            parse_gac(data)
        assert e.value.field == field
    assert store.roms.of_wing(wid) == before
