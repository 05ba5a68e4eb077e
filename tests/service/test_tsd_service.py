"""TSD ROMs in the service: identity with the wing's section, stored mean flow, its JSON and PNG endpoints."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from api.schemas import RomRequest
from romams.services.training import allowed_options, default_orders, rom_identity, section_options
from romams.settings import Settings
from romams_core.mesh import standard_mesh
from romams_core.training_tsd import TSD_ORDERS, train_tsd_rom, tsd_n_steps
from romams_core.wing import template


def test_identity_carries_the_wing_section():
    agard, delta = template("agard-445.6"), template("cropped-delta")
    assert section_options(agard) == {"thickness_form": "naca65a004", "thickness_to_chord": 0.03994}
    assert section_options(delta) == {"thickness_form": None, "thickness_to_chord": 0.0}
    ident = rom_identity("tsd", 8, 8, {"grid_scale": 0.5}, wing=agard)
    assert ident["options"] == {"anchor_k": [0.025, 0.05, 0.1], "grid_scale": 0.5, "supercritical_refine": 1.5,
                                "thickness_form": "naca65a004", "thickness_to_chord": 0.03994,
                                "validation_band": 3.0}  # with the defaults
    assert rom_identity("tsd", options={"supercritical_refine": None}, wing=agard)["options"][
        "supercritical_refine"] is None  # the requested grid kept: another ROM
    for plain in (None, []):  # both ask for a plain ROM: one identity
        assert rom_identity("tsd", options={"anchor_k": plain}, wing=agard)["options"]["anchor_k"] is None
    # an explicit section wins; other solvers ignore the wing
    assert rom_identity("tsd", options={"thickness_to_chord": 0.03}, wing=agard)["options"]["thickness_to_chord"] \
        == 0.03
    assert rom_identity("dlm", wing=agard)["options"] == {}
    assert {"grid_scale", "thickness_form", "linearity_check", "tsd_dt", "anchor_k", "anchor_hold",
            "supercritical_refine", "validation_band"} \
        <= allowed_options("tsd")


def test_default_arx_orders_are_the_solvers():
    # 8/8 for the TSD (docs/transonic.md 7.2: 12/12 is unsafe at M 0.95) and the UVLM, but each solver's own
    assert TSD_ORDERS == (8, 8) == default_orders("tsd") and default_orders("uvlm") == (8, 8)
    assert default_orders("dlm") == (0, 0) == default_orders("external:nastran")
    body = RomRequest(mach=0.87, solver="tsd")  # a request without orders gets the solver's
    ident = rom_identity(body.solver, body.na, body.nb)
    assert (ident["na"], ident["nb"]) == TSD_ORDERS and rom_identity("uvlm")["na"] == 8
    assert rom_identity("tsd", 6, None)["na"] == 6 and rom_identity("tsd", 6, None)["nb"] == TSD_ORDERS[1]
    assert rom_identity("dlm", 12, 12)["na"] == 0
    # the record grows with the orders: 16 samples per ARX parameter per output, 8 shapes
    assert tsd_n_steps(8, 12, 12, 0.1) == 3072 and tsd_n_steps(8, 8, 8, 0.1) == 2048


@pytest.fixture(scope="module")
def tiny_tsd_rom():
    """A one-shape TSD ROM of the AGARD wing (NACA 65A004) on a half grid with short signals (seconds)."""
    wing = template("agard-445.6")
    mesh = standard_mesh(wing.planform)
    eta = mesh.y / wing.planform.semispan
    rom = train_tsd_rom(mesh, (0.01 * eta ** 2)[:, None], 0.9, na=2, nb=2, n_steps=200, grid_scale=0.5,
                        thickness_form="naca65a004", thickness_to_chord=0.04, nrmse_tol=1.0, anchor_k=None)
    return wing, rom


def test_tsd_rom_keeps_its_mean_flow(tiny_tsd_rom):
    _, rom = tiny_tsd_rom
    mf = rom.mean_flow
    assert rom.solver == "tsd" and mf is not None and mf["mach"] == 0.9
    up, lo = np.asarray(mf["cp_upper"]), np.asarray(mf["cp_lower"])
    assert up.shape == lo.shape == (len(mf["x_over_c"]), len(mf["eta"]))
    assert np.allclose(up, lo, atol=1e-9)  # symmetric section at zero incidence
    assert up.min() < -0.05 and mf["cp_star"] == pytest.approx(-2 * (1 - 0.81) / (2.4 * 0.81))
    assert rom.summary()["mean_flow_steps"] == mf["steady_steps"]


def test_mean_flow_endpoints(tiny_tsd_rom, tmp_path):
    wing, rom = tiny_tsd_rom
    app = create_app(Settings(data_dir=tmp_path), sweeper=False)
    with TestClient(app) as client:
        store = client.app.state.service.store
        wid = client.post("/api/v1/wings", json={"template": "agard-445.6"}).json()["id"]
        snaps = np.linalg.qr(np.random.default_rng(0).standard_normal((store_nodes(wing), 3)))[0]
        from romams_core.basis import build_basis

        bid = store.bases.save(wid, build_basis(snaps, n_modes=1), {"samples": 3, "modes": 1})
        rid = store.roms.save(wid, bid, rom, rom_identity("tsd", 2, 2, wing=wing))
        body = client.get(f"/api/v1/roms/{rid}/mean-flow").json()
        assert body["mach"] == 0.9 and len(body["cp_upper"]) == len(body["x_over_c"])
        assert body["far_field"] == "wake"  # the outer faces the mean flow was solved with
        assert body["grid"]["n_chord"] == 20  # the grid it was solved on: the default 40 chord cells x 0.5
        png = client.get(f"/api/v1/roms/{rid}/mean-flow.png")
        assert png.status_code == 200 and png.headers["content-type"] == "image/png" and png.content[:4] == b"\x89PNG"
        missing = client.get("/api/v1/roms/999999/mean-flow")
        assert missing.status_code == 404 and missing.json()["field"] == "rom_id"
        page = client.get("/dashboard").text
        assert f"/api/v1/roms/{rid}/mean-flow.png" in page


def store_nodes(wing) -> int:
    """Number of standard-mesh nodes of a wing."""
    return standard_mesh(wing.planform).n_nodes
