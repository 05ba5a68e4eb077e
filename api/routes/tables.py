"""Imported aerodynamic models: a GAF table uploaded for a wing's basis becomes the ROM of solver
"external:<label>" (``romams.services.gaf_import``, the use case of ``romams train --gaf``)."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.concurrency import run_in_threadpool

from api.deps import Service, form_int, no_nul, require_key, service, wing_or_404
from api.openapi import FOUND, READ, WING, WRITE, problems
from api.problems import Problem, invalid
from api.responses import BasisOut, RomOut, ok
from api.routes.wings import _basis_or_404, _basis_wing
from api.schemas import SnapshotBasisRequest
from romams.services.gaf_import import LABEL, MAX_TABLE_BYTES, QHH_FIELDS, import_table, parse_k_list, parse_table
from romams.services.models import resolve_basis_id
from romams_core.aero.protocol import check_mach

router = APIRouter(tags=["wings"], responses=READ)

#: the text fields of a table upload (besides the file ``file``)
TABLE_FIELDS = ("label", "mach", "basis_id", "n_lags", *QHH_FIELDS)
#: the largest Mach block index and mode count to skip of a Nastran QHH upload
MAX_QHH_INDEX = 10_000
TABLE_BODY = {"requestBody": {"required": True, "content": {"multipart/form-data": {"schema": {
    "type": "object", "required": ["file", "label"], "additionalProperties": False,
    "description": "a GAF table computed on the basis shapes (in the basis' order): NPZ with k, gaf_real, gaf_imag "
                   "[nk, m, m] (m^3 per unit generalized displacement, k on the semichord) and mach; CSV with the "
                   "header k,row,col,real,imag (then mach is required); or Nastran's QHH (excluding the dynamic "
                   "pressure) from an OUTPUT4 file (.op4, ASCII or binary) or a punch file of DMIG cards (.pch): "
                   "h rows and h columns per m-k pair, the pairs in MKAERO1 order (every k of a Mach, then the next "
                   "Mach), as one wide matrix or one matrix per pair; then mach and k_values are required",
    "properties": {
        "file": {"type": "string", "format": "binary"},
        "label": {"type": "string", "pattern": f"^{LABEL.pattern}$",
                  "description": "the table's name: its ROM's solver is external:<label>"},
        "mach": {"type": "number", "minimum": 0, "exclusiveMaximum": 1,
                 "description": "the Mach number (required for a CSV table and a Nastran QHH; an NPZ table carries "
                                "its own)"},
        "basis_id": {"type": "integer", "minimum": 1, "description": "the basis (default: the wing's active one)"},
        "n_lags": {"type": "integer", "minimum": 0, "maximum": 12,
                   "description": "RFA lag roots (default: automatic, as for the DLM)"},
        "k_values": {"type": "string", "description": "Nastran QHH only (required): the MKAERO1 reduced frequencies "
                                                      "of one Mach, in the card's order, separated by commas "
                                                      "(Nastran's k, on REFC/2)"},
        "matrix": {"type": "string", "pattern": "^[A-Za-z][A-Za-z0-9_]{0,7}$",
                   "description": "Nastran QHH only: the matrix name (default QHH)"},
        "mach_index": {"type": "integer", "minimum": 0, "maximum": MAX_QHH_INDEX,
                       "description": "Nastran QHH only: which Mach block of the file, from 0 (default 0)"},
        "skip_modes": {"type": "integer", "minimum": 0, "maximum": MAX_QHH_INDEX,
                       "description": "Nastran QHH only: leading modes (rows and columns) that are not basis shapes, "
                                      "dropped (default 0); the rest must be the basis shapes in their order"},
        "refc": {"type": "number", "exclusiveMinimum": 0,
                 "description": "Nastran QHH only: the AERO card's REFC (m); k is rescaled by c_ref / REFC "
                                "(default: the wing's recorded REFC, else its c_ref: no rescaling)"}}}}}}}


def _qhh_fields(text: dict[str, str]) -> dict[str, Any]:
    """The Nastran QHH settings of a table upload (None where absent; 422 naming a malformed one)."""
    refc = text.get("refc") or ""
    try:
        length = float(refc) if refc else None
    except ValueError:
        raise invalid("refc", f"must be a length in m, got {refc[:20]!r}") from None
    return {"k_values": parse_k_list(text["k_values"]) if text.get("k_values") else None,
            "matrix": text.get("matrix") or None, "refc": length,
            "mach_index": form_int(text, "mach_index", 0, MAX_QHH_INDEX),
            "skip_modes": form_int(text, "skip_modes", 0, MAX_QHH_INDEX)}


def _mach_field(text: dict[str, str]) -> float:
    """The Mach number text field, in [0, 1) (``check_mach``; 422 naming ``mach`` otherwise)."""
    try:
        return check_mach(float(text["mach"]), upper=1.0)
    except ValueError as exc:  # not a number, or out of range (an InputError)
        raise invalid("mach", getattr(exc, "reason", f"must be a number, got {text['mach'][:20]!r}")) from None


async def _read_form(request: Request, fields: tuple[str, ...] = TABLE_FIELDS, max_bytes: int = MAX_TABLE_BYTES
                     ) -> tuple[bytes, str, dict[str, str]]:
    """(file bytes (at most max_bytes + 1 read), file name, text fields) of a multipart upload of one file and
    ``fields`` (422 naming the field otherwise)."""
    if not request.headers.get("content-type", "").lower().startswith("multipart/form-data"):
        raise invalid("file", f"send multipart/form-data (fields file, {', '.join(fields)})")
    form = await request.form(max_files=1, max_fields=len(fields))
    try:
        upload = form.get("file")
        if upload is None or isinstance(upload, str):
            raise invalid("file", "missing: the table file (NPZ or CSV)")
        text = {k: v for k, v in form.multi_items() if k != "file"}
        unknown = sorted(set(text) - set(fields))
        if unknown:
            raise invalid(unknown[0], f"not a field of this upload; allowed: file, {', '.join(fields)}")
        if any(not isinstance(v, str) for v in text.values()):
            raise invalid(next(k for k, v in text.items() if not isinstance(v, str)), "must be a text field")
        data = await upload.read(max_bytes + 1)
        return data, str(upload.filename or ""), {k: str(v) for k, v in text.items()}
    finally:
        await form.close()


NPZ = {200: {"description": "NPZ file: x, y (standard-mesh nodes, m, n_nodes), shapes [n_nodes, m] (out-of-plane "
                              "displacement, m), c_ref (m), basis_id", "content": {"application/octet-stream": {
                                  "schema": {"type": "string", "format": "binary"}}}}}


@router.get("/bases/{basis_id}/shapes.npz", response_class=Response, responses={**FOUND, **NPZ})
def basis_shapes_npz(basis_id: int, svc: Service = Depends(service)) -> Response:
    """The basis shapes as arrays, for a GAF table computed elsewhere: the standard-mesh nodes x, y (m), the
    shapes [n_nodes, m] (out-of-plane displacement, m, +z up) in the basis' order, c_ref (m)."""
    from romams_core.mesh import standard_mesh

    basis = _basis_or_404(svc, basis_id)
    mesh = standard_mesh(_basis_wing(svc, basis_id).planform)
    buf = io.BytesIO()
    np.savez(buf, x=mesh.x, y=mesh.y, shapes=basis.shapes, c_ref=np.float64(mesh.c_ref), basis_id=np.int64(basis_id))
    return Response(buf.getvalue(), media_type="application/octet-stream",
                    headers={"Content-Disposition": f'attachment; filename="basis_{basis_id}_shapes.npz"'})


@router.post("/wings/{wing}/roms/gaf", status_code=201, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **problems(409, 413), **ok(RomOut, "the ROM fitted to the table", 201)},
             openapi_extra=TABLE_BODY)
async def import_gaf_table(wing: str, request: Request, svc: Service = Depends(service)) -> dict[str, Any]:
    """Import a GAF table (your CFD's or doublet lattice's forces on the basis shapes, or Nastran's QHH from an
    OUTPUT4 or punch file) as the ROM of solver ``external:<label>`` at its Mach number: fitted by the DLM's
    rational function approximation, replacing an earlier table of that label and Mach; flutter requests use it
    with ``"solver": "external:<label>"``."""
    wid, wdef = wing_or_404(svc, wing)
    data, filename, text = await _read_form(request)
    no_nul(text, "form")
    if "label" not in text:
        raise invalid("label", "missing: the table's name (its ROM's solver is external:<label>)")
    mach = _mach_field(text) if text.get("mach") else None
    basis_id = resolve_basis_id(svc.store, wid, form_int(text, "basis_id", 1, 2**53))
    n_lags = form_int(text, "n_lags", 0, 12)
    try:
        table = await run_in_threadpool(parse_table, data, filename, mach, _qhh_fields(text), wdef)
    except ImportError as exc:
        raise Problem(501, "file: Nastran support (pyNastran) is not installed on this server", "file") from exc
    basis = svc.store.bases.load(basis_id)
    fit = {} if n_lags is None else {"n_lags": n_lags}
    rom_id, _ = await run_in_threadpool(import_table, svc.store, wid, wdef, basis_id, basis, table, text["label"],
                                        **fit)
    return next(r for r in svc.store.roms.of_wing(wid, basis_id) if r["id"] == rom_id)


#: the text fields of a GAC upload (besides the file ``file``)
GAC_FIELDS = ("label", "mach", "basis_id", "settings")
GAC_BODY = {"requestBody": {"required": True, "content": {"multipart/form-data": {"schema": {
    "type": "object", "required": ["file", "label", "mach", "settings"], "additionalProperties": False,
    "description": "the GAC time histories [2 n_steps, m] (m^3) an external CFD run computed for the excitation of "
                   "GET /wings/{wing}/external-package: NPZ (array gac) or CSV (header g_0,...,g_{m-1})",
    "properties": {
        "file": {"type": "string", "format": "binary"},
        "label": {"type": "string", "pattern": f"^{LABEL.pattern}$",
                  "description": "a name: the ROM's solver is external:<label>"},
        "mach": {"type": "number", "minimum": 0, "exclusiveMaximum": 1},
        "basis_id": {"type": "integer", "minimum": 1, "description": "default: the package's (settings), else the "
                                                                     "wing's active basis"},
        "settings": {"type": "string", "description": "settings.json of the package, unchanged (JSON text)"}}}}}}}


PACKAGE = {200: {"description": "zip: excitation.npz, excitation.csv, shapes.csv, settings.json, README.md",
                 "content": {"application/zip": {"schema": {"type": "string", "format": "binary"}}}}}


@router.get("/wings/{wing}/external-package", response_class=Response,
            responses={**WING, **problems(409), **PACKAGE})
def external_package(wing: str, mach: float = Query(ge=0.0, lt=1.0), basis_id: int | None = Query(default=None, ge=1,
                     le=2**53), na: int = Query(default=8, ge=1, le=40), nb: int = Query(default=8, ge=1, le=40),
                     n_steps: int | None = Query(default=None, ge=16, le=200_000),
                     seed: int = Query(default=0, ge=0, le=2**31), svc: Service = Depends(service)) -> Response:
    """The training package of the wing's basis at one Mach for an external CFD code (the ROM-AMS paper's way):
    the basis shapes on the standard mesh, the excitation (one continued run: training then validation half),
    the settings to send back, and a README with the conventions (GAC, time, units)."""
    from romams.services.external_cfd import export_package

    wid, wdef = wing_or_404(svc, wing)
    bid = resolve_basis_id(svc.store, wid, basis_id)
    options: dict[str, Any] = {"na": na, "nb": nb, "seed": seed, **({} if n_steps is None else {"n_steps": n_steps})}
    data, _ = export_package(wdef, bid, _basis_or_404(svc, bid), mach, options)
    return Response(data, media_type="application/zip", headers={
        "Content-Disposition": f'attachment; filename="romams_package_wing{wid}_basis{bid}_M{mach:g}.zip"'})


@router.post("/wings/{wing}/roms/gac", status_code=201, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **problems(409, 413), **ok(RomOut, "the ROM identified from the GAC", 201)},
             openapi_extra=GAC_BODY)
async def import_gac_histories(wing: str, request: Request, svc: Service = Depends(service)) -> dict[str, Any]:
    """Identify the ARX ROM of the GAC time histories an external CFD run computed for a training package, as for
    a built-in solver, and store it as solver ``external:<label>`` (replacing an earlier one of that label and
    Mach). A flutter request uses it with ``"solver": "external:<label>"``."""
    import json

    from romams.services.external_cfd import MAX_GAC_BYTES, import_gac, parse_gac

    wid, wdef = wing_or_404(svc, wing)
    data, filename, text = await _read_form(request, GAC_FIELDS, MAX_GAC_BYTES)
    no_nul(text, "form")
    for key in ("label", "mach", "settings"):
        if key not in text:
            raise invalid(key, "missing")
    mach = _mach_field(text)
    try:
        settings = json.loads(text["settings"])
    except ValueError:
        raise invalid("settings", "must be the package's settings.json (JSON text)") from None
    if not isinstance(settings, dict):
        raise invalid("settings", "must be a JSON object")
    given = form_int(text, "basis_id", 1, 2**53) or settings.get("basis_id")
    bid = resolve_basis_id(svc.store, wid, given if isinstance(given, int) else None)
    gac = parse_gac(data, filename)
    basis = _basis_or_404(svc, bid)
    rom_id, _ = await run_in_threadpool(import_gac, svc.store, wid, wdef, bid, basis, mach, gac, text["label"],
                                        {k: v for k, v in settings.items() if k != "basis_id"})
    return next(r for r in svc.store.roms.of_wing(wid, bid) if r["id"] == rom_id)


@router.post("/wings/{wing}/basis/snapshots", status_code=201, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **ok(BasisOut, "the basis built from the uploaded mode sets", 201)})
def snapshot_basis_route(wing: str, body: SnapshotBasisRequest, svc: Service = Depends(service)) -> dict[str, Any]:
    """Build a PCA basis from mode sets you uploaded (POST /modes), one per design of a design space the service
    cannot compute itself; it becomes the wing's active basis when the wing has none. New designs are then
    evaluated from their uploaded modes (``modes_id``) against it, with the usual MAC checks."""
    from romams.services.models import activate_first_basis
    from romams.services.snapshot_basis import snapshot_basis

    wid, wdef = wing_or_404(svc, wing)
    sets = []
    for i, mid in enumerate(body.modes_ids):
        try:
            sets.append(svc.store.modes.load(mid))
        except KeyError:
            raise Problem(404, f"modes_ids[{i}]: no uploaded modes {mid}", f"modes_ids[{i}]") from None
    basis = snapshot_basis(wdef, sets, body.modes, body.mac_threshold, body.max_basis)
    params = {"snapshots": list(body.modes_ids), "modes": body.modes, "mac_threshold": body.mac_threshold,
              "max_basis": body.max_basis}
    bid = svc.store.bases.save(wid, basis, params)
    activate_first_basis(svc.store, wid, bid)
    return next(b for b in svc.store.bases.of_wing(wid) if b["id"] == bid)
