"""Nastran over HTTP: POST /wings with a deck upload (files or a zip, INCLUDEs), POST /modes with an OP2 and its
read options, GET /schemas/wing; bad uploads give 4xx problems naming the field and no server path.

No worker runs here: everything is checked and stored by the API itself.
"""

from __future__ import annotations

import io
import os
import tempfile
import zipfile

import nastran_decks as nd  # tests/nastran_decks.py: skips this module without pyNastran (not under CI)
import numpy as np
import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from romams.settings import Settings
from romams_core.mesh import Planform

STICK = Planform(root_chord=0.3, tip_chord=0.3, semispan=0.5, sweep_le=0.0, n_chord=6, n_span=10)


@pytest.fixture()
def client(tmp_path):
    app = create_app(Settings(data_dir=tmp_path / "data"), sweeper=False)
    with TestClient(app) as c:
        yield c


AERO_CARDS = ("CAERO1", "PAERO1", "AEFACT", "AERO")


@pytest.fixture()
def deck(tmp_path):
    """The stick model as a main deck and an INCLUDE file holding its aerodynamic cards, plus its OP2."""
    bdf, op2, _, _ = nd.stick_deck(tmp_path, STICK)
    cards: list[list[str]] = []
    for line in bdf.read_text().splitlines():
        if line[:1] in (" ", "*", "+") and cards:
            cards[-1].append(line)  # a continuation line
        else:
            cards.append([line])
    aero = [c for c in cards if c[0].split()[0] in AERO_CARDS] if cards else []
    main = [c for c in cards if c not in aero]
    begin = next(i for i, c in enumerate(main) if c[0].startswith("BEGIN BULK"))
    main.insert(begin + 1, ["INCLUDE 'aero.bdf'"])
    text = {"main": main, "aero": aero}
    out = {k: "\n".join(ln for c in v for ln in c).encode() + b"\n" for k, v in text.items()}
    out["anti"] = out["aero"].replace(next(c[0] for c in aero if c[0].startswith("AERO ")).encode(),
                                      b"AERO,0,100.,.3,1.225,-1")
    assert out["anti"] != out["aero"] and b"CAERO1" in out["aero"] and b"CAERO1" not in out["main"]
    return {**out, "op2": op2.read_bytes()}


def _zip(files: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in files.items():
            zf.writestr(name, data)
    return buf.getvalue()


def problem(r, status: int, field: str | None = None, contains: str = "") -> dict:
    """A problem+json with this status (field, text) whose body names no folder of the server."""
    assert r.status_code == status, (r.status_code, r.text)
    assert r.headers["content-type"].startswith("application/problem+json")
    body = r.json()
    if field is not None:
        assert body.get("field") == field, body
    assert contains.lower() in body["detail"].lower(), body
    for secret in (tempfile.gettempdir(), "romams-upload", os.getcwd()):
        assert secret not in r.text, r.text
    return body


def test_wing_from_a_zipped_deck_with_include(client, deck):
    z = _zip({"model/main.bdf": deck["main"], "model/aero.bdf": deck["aero"]})
    r = client.post("/api/v1/wings", files={"bdf": ("stick.zip", z)}, data={"name": "stick-zip"})
    assert r.status_code == 201, r.text
    view = client.get(f"/api/v1/wings/{r.json()['id']}").json()
    d = view["definition"]
    assert d["structure"] is None and d["symmetry"] == "symmetric" and d["origin"] == [0.0, 0.0, 0.0]
    assert d["planform"]["semispan"] == pytest.approx(0.5) and d["planform"]["n_span"] == 10
    assert view["has_baseline"] is False
    files = [("bdf", ("main.bdf", deck["main"])), ("bdf", ("aero.bdf", deck["aero"]))]  # several files
    r = client.post("/api/v1/wings", files=files, data={"name": "stick-files", "n_chord": "4"})
    assert r.status_code == 201, r.text
    assert client.get("/api/v1/wings/stick-files").json()["definition"]["planform"]["n_chord"] == 4
    schema = client.get("/api/v1/schemas/wing").json()
    import jsonschema_rs

    validator = jsonschema_rs.validator_for(schema)
    validator.validate(d)
    validator.validate(client.get("/api/v1/wings/stick-files").json()["definition"])
    assert not validator.is_valid({**d, "symmetry": "sideways"})


def test_cranked_deck_upload(client, tmp_path):
    """Three CAERO1s with a bend: the stored wing has the kink, and the served schema validates it (and refuses
    a kink that is not a [y, x_le, chord] triple)."""
    data = nd.crank_deck(tmp_path / "crank.bdf").read_bytes()
    r = client.post("/api/v1/wings", files={"bdf": ("crank.bdf", data)}, data={"name": "crank"})
    assert r.status_code == 201, r.text
    d = client.get("/api/v1/wings/crank").json()["definition"]
    np.testing.assert_allclose(d["planform"]["kinks"], [[1.0, 0.1, 0.8]], rtol=1e-12)
    import jsonschema_rs

    schema = client.get("/api/v1/schemas/wing").json()
    jsonschema_rs.validator_for(schema).validate(d)
    bad = {**d, "planform": {**d["planform"], "kinks": [[1.0, 0.1]]}}
    assert not jsonschema_rs.validator_for(schema).is_valid(bad)


def test_bad_deck_uploads(client, deck):
    problem(client.post("/api/v1/wings", files={"bdf": ("main.bdf", deck["main"])}), 422, "bdf",
            "INCLUDE 'aero.bdf' is not among the uploaded files")
    for bad in ("/etc/passwd", "../aero.bdf", "$HOME/aero.bdf"):
        main = deck["main"].replace(b"INCLUDE 'aero.bdf'", f"INCLUDE '{bad}'".encode())
        problem(client.post("/api/v1/wings", files={"bdf": ("main.bdf", main)}), 422, "bdf",
                "must name a file of the upload")
    problem(client.post("/api/v1/wings", files={"bdf": ("junk.bdf", b"\x00\x01garbage\nCAERO1,x\n")}), 422, "bdf")
    problem(client.post("/api/v1/wings", files={"bdf": ("a.zip", _zip({"../evil.bdf": b"x"}))}), 422, "bdf",
            "names must be relative")
    problem(client.post("/api/v1/wings", files={"bdf": ("a.zip", b"PK\x03\x04broken")}), 422, "bdf")
    problem(client.post("/api/v1/wings", files={"bdf": ("notes.txt", b"hello")}), 422, "bdf", "no deck file")
    both = [("bdf", ("main.bdf", deck["main"])), ("bdf", ("aero.bdf", deck["aero"]))]
    problem(client.post("/api/v1/wings", files=both, data={"colour": "red"}), 422, "colour", "not a field")
    problem(client.post("/api/v1/wings", files=both, data={"n_span": "0"}), 422, "n_span")
    problem(client.post("/api/v1/wings", files=both, data={"units": "furlong"}), 422, "units")
    anti_files = [("bdf", ("main.bdf", deck["main"])), ("bdf", ("aero.bdf", deck["anti"]))]
    r = client.post("/api/v1/wings", files=anti_files, data={"name": "anti"})  # the deck's SYMXZ = -1
    assert r.status_code == 201 and client.get("/api/v1/wings/anti").json()["definition"]["symmetry"] == \
        "antisymmetric", r.text
    r = client.post("/api/v1/wings", files=anti_files, data={"symmetry": "symmetric", "name": "anti-as-sym"})
    assert r.status_code == 201, r.text
    problem(client.post("/api/v1/wings", files=anti_files, data={"symmetry": "symmetric", "name": "anti-as-sym"}),
            409, "name", "already exists")
    assert [w["name"] for w in client.get("/api/v1/wings").json()] == ["anti", "anti-as-sym"]


def test_planform_only_json_definition(client):
    d = {"name": "bare", "planform": {"root_chord": 1.0, "tip_chord": 0.5, "semispan": 2.0}, "structure": None,
         "origin": [3.0, 0.0, 0.5]}
    r = client.post("/api/v1/wings", json={"definition": d})
    assert r.status_code == 201, r.text
    problem(client.post("/api/v1/wings/bare/basis", json={"samples": 4}), 422, "wing", "planform-only")
    assert client.post("/api/v1/wings", json={"definition": {**d, "name": "free", "symmetry": "none"}}
                       ).status_code == 201  # a free wing (the dlm models it)
    problem(client.post("/api/v1/wings", json={"definition": {**d, "name": "m", "symmetry": "mirrored"}}), 422,
            "definition.symmetry", "must be one of")
    problem(client.post("/api/v1/wings", json={"definition": {**d, "name": "o", "origin": [1, 2]}}), 422,
            "definition.origin")


def test_modes_upload_with_options(client, deck):
    files = [("bdf", ("deck.zip", _zip({"main.bdf": deck["main"], "aero.bdf": deck["aero"]}))),
             ("op2", ("stick.op2", deck["op2"]))]
    r = client.post("/api/v1/modes", files=files, data={"modes": "1,3", "grids": "planform"})
    assert r.status_code == 201, r.text
    assert r.json()["n_modes"] == 2 and r.json()["n_nodes"] == 11
    problem(client.post("/api/v1/modes", files=files, data={"modes": "1,9"}), 422, "modes", "not among the kept")
    problem(client.post("/api/v1/modes", files=files, data={"subcase": "4"}), 422, "subcase", "not in model.op2")
    problem(client.post("/api/v1/modes", files=files, data={"spline": "cubic"}), 422, "spline")
    bad_op2 = [files[0], ("op2", ("x.op2", b"\x00" * 200))]
    problem(client.post("/api/v1/modes", files=bad_op2), 422, "op2", "cannot read model.op2")
