"""Wings, bases and ROM training endpoints."""

from __future__ import annotations

import dataclasses
import json
import math
import tempfile
from pathlib import Path
from typing import Any, Literal

from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError

from api.deps import WING_NAME_MAX, Service, form_int, no_nul, require_key, service, wing_or_404
from api.openapi import FOUND, IMAGE, READ, WING, WRITE, problems
from api.plot_cache import NOT_MODIFIED, plot_response
from api.problems import Problem, from_value_error, invalid
from api.responses import (
    ActiveBasisOut,
    BasisOut,
    JsonSchemaDocument,
    MeanFlow,
    RomJob,
    RomJobs,
    RomOut,
    WingDetail,
    WingSummary,
    ok,
)
from api.schemas import ActiveBasis, BasisRequest, Created, JobRef, RomRequest, WingCreate
from api.uploads import MAX_DECK_FILES, save_deck
from romams.jobs import submit
from romams.persistence import ID_MAX, ID_MIN, content_hash, rom_key
from romams.services.errors import ServiceError
from romams.services.models import resolve_basis_id
from romams.services.training import allowed_options, available, check_options, rom_identity

router = APIRouter(tags=["wings"], responses=READ)



def wing_view(wid: int, wing: Any, svc: Service) -> dict[str, Any]:
    """JSON view of a wing with its design variables, bases and ROMs."""
    info = svc.store.wings.info(wid) or {}
    dvs = [{"name": v.name, "lower": v.lower, "upper": v.upper, "unit": v.unit, "description": v.description}
           for v in getattr(wing, "design_variables", ())]
    return {"id": wid, "name": info.get("name"), "created_at": info.get("created_at"),
            "design_variables": dvs, "has_baseline": bool(getattr(wing, "has_baseline", False)),
            "latest_basis_id": svc.store.bases.latest_id(wid), "active_basis_id": svc.store.wings.active_basis(wid),
            "trained_machs": sorted({r["mach"] for r in svc.store.roms.of_wing(wid)}),
            "definition": info.get("definition", {}).get("data")}


def _create(svc: Service, wing: Any, name: str | None) -> dict[str, int]:
    """Store a wing under ``name`` (default its own); 409 when the name is taken."""
    if len(wing.name) > WING_NAME_MAX:
        raise invalid("definition.name", f"at most {WING_NAME_MAX} characters, got {len(wing.name)}")
    try:
        wid = svc.store.wings.create(wing, name)
    except ValueError as exc:
        raise Problem(409, str(exc), "name") from exc
    return {"id": wid}


def _wing_from_body(body: WingCreate) -> Any:
    """WingDefinition of a JSON request: a template (renamed) or a full definition."""
    from romams_core import wing as wing_mod

    no_nul(body.definition, "definition")
    try:
        if body.template is not None:
            wing = wing_mod.template(body.template)
        else:
            wing = wing_mod.WingDefinition.from_dict(body.definition or {})
    except ValueError as exc:
        raise from_value_error(exc, "template" if body.template is not None else "definition") from exc
    except (KeyError, TypeError, AttributeError) as exc:
        raise invalid("definition", f"malformed wing definition ({type(exc).__name__}: {exc})") from exc
    if body.name:
        try:
            wing = dataclasses.replace(wing, name=body.name)
        except ValueError as exc:
            raise from_value_error(exc) from exc
    return wing


async def _json_body(request: Request) -> WingCreate:
    """The JSON body as a WingCreate; 422 problems as FastAPI's own body validation words them."""
    raw = await request.body()
    try:
        data = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise RequestValidationError([{"type": "json_invalid", "loc": ("body", getattr(exc, "pos", 0)),
                                       "msg": "JSON decode error", "input": {}}]) from None
    try:
        return WingCreate.model_validate(data)
    except ValidationError as exc:
        raise RequestValidationError([{**e, "loc": ("body", *e["loc"])} for e in exc.errors(include_url=False)]
                                     ) from None


async def _wing_from_upload(request: Request, svc: Service) -> tuple[Any, str | None]:
    """(WingDefinition, name) of a multipart upload of a Nastran deck (CAERO1 / AERO(S) planform)."""
    form = await request.form(max_files=MAX_DECK_FILES, max_fields=16)
    try:
        return await _wing_from_form(form, svc)
    finally:
        await form.close()  # the spooled upload files


async def _wing_from_form(form: Any, svc: Service) -> tuple[Any, str | None]:
    """(WingDefinition, name) of the parsed multipart form of a wing upload."""
    from romams.wing_files import load_wing_file

    fields = {k: v for k, v in form.multi_items() if k != "bdf"}
    unknown = sorted(set(fields) - set(UPLOAD_FIELDS))
    if unknown:
        raise invalid(unknown[0], f"not a field of a wing upload; allowed: bdf (files), {', '.join(UPLOAD_FIELDS)}")
    text = {k: v for k, v in fields.items() if isinstance(v, str)}
    if len(text) != len(fields):
        raise invalid(next(k for k in fields if k not in text), "must be a text field, not a file")
    no_nul(text, "form")
    ints = {key: n for key in ("n_chord", "n_span") if (n := form_int(text, key, 1, 200)) is not None}
    name = text.get("name") or None
    if name is not None and not 1 <= len(name) <= WING_NAME_MAX:
        raise invalid("name", f"1..{WING_NAME_MAX} characters")
    with tempfile.TemporaryDirectory(prefix="romams-upload-") as tmp:
        deck = await save_deck(form.getlist("bdf"), Path(tmp), svc.settings.upload_max_bytes,
                               svc.settings.upload_inflated_max_bytes)
        try:
            wing = await run_in_threadpool(load_wing_file, deck, name=name, units=text.get("units") or "si",
                                           symmetry=text.get("symmetry") or None, confine=True, **ints)
        except ImportError as exc:
            raise Problem(501, "bdf: Nastran support (pyNastran) is not installed on this server", "bdf") from exc
    return wing, name


#: the text fields of a multipart wing upload (besides the deck files ``bdf``)
UPLOAD_FIELDS = ("name", "units", "symmetry", "n_chord", "n_span")
WING_BODY = {"requestBody": {"required": True, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/WingCreate"}},
    "multipart/form-data": {"schema": {
        "type": "object", "required": ["bdf"], "additionalProperties": False,
        "description": "a Nastran deck (one file, several files: the main deck and its INCLUDE files, or a zip) "
                       "whose CAERO1 panels and AERO/AEROS card make a planform-only wing",
        "properties": {
            "bdf": {"type": "array", "items": {"type": "string", "format": "binary"}, "minItems": 1},
            "name": {"type": "string", "minLength": 1, "maxLength": WING_NAME_MAX},
            "units": {"type": "string", "enum": ["si", "mm-t-s", "in-lbf-s", "ft-lbf-s"]},
            "symmetry": {"type": "string", "enum": ["symmetric", "antisymmetric", "none"],
                         "description": "override the deck's AERO/AEROS symmetry (the dlm, the uvlm and the tsd "
                                        "model all three)"},
            "n_chord": {"type": "integer", "minimum": 1, "maximum": 200},
            "n_span": {"type": "integer", "minimum": 1, "maximum": 200}}}}}}}


@router.post("/wings", status_code=201, response_model=Created, dependencies=[Depends(require_key)],
             responses={**WRITE, **problems(409, 501)}, openapi_extra=WING_BODY)
async def create_wing(request: Request, svc: Service = Depends(service)) -> dict[str, int]:
    """Create a wing: JSON ({"template": "cropped-delta", "name": ...} or {"definition": ...}), or a multipart
    upload of a Nastran deck (``bdf``: files or a zip; ``name``, ``units``, ``symmetry``, ``n_chord``, ``n_span``)
    whose CAERO1 / AERO(S) cards give a planform-only wing (its modes then come from POST /modes)."""
    if request.headers.get("content-type", "").lower().startswith("multipart/form-data"):
        try:
            wing, name = await _wing_from_upload(request, svc)
        except ValueError as exc:
            field = getattr(exc, "field", "")
            raise from_value_error(exc, "" if field in UPLOAD_FIELDS else "bdf") from exc
    else:
        body = await _json_body(request)
        wing, name = _wing_from_body(body), body.name
    return await run_in_threadpool(_create, svc, wing, name)


@router.get("/schemas/wing", responses=ok(JsonSchemaDocument, "the JSON Schema of a wing definition"))
def wing_schema() -> dict[str, Any]:
    """JSON Schema of a wing definition (the ``definition`` of POST /wings; ``romams wing schema``)."""
    from romams.wing_files import wing_schema as schema

    return schema()


@router.get("/wings", responses=ok(list[WingSummary], "every stored wing, by id"))
def list_wings(svc: Service = Depends(service)) -> list[dict[str, Any]]:
    """All stored wings."""
    out = []
    with svc.store.unit_of_work() as uow:  # one session for the whole listing
        for w in uow.wings.all():
            w["latest_basis_id"] = uow.bases.latest_id(w["id"])
            w["active_basis_id"] = uow.wings.active_basis(w["id"])
            w["trained_machs"] = sorted({r["mach"] for r in uow.roms.of_wing(w["id"])})
            out.append(w)
    return out


@router.get("/wings/{wing}", responses={**WING, **ok(WingDetail, "the wing")})
def get_wing(wing: str, svc: Service = Depends(service)) -> dict[str, Any]:
    """One wing (by id or name) with its design variables."""
    wid, w = wing_or_404(svc, wing)
    return wing_view(wid, w, svc)


@router.post("/wings/{wing}/basis", status_code=202, response_model=JobRef, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, 200: {"model": JobRef, "description": "the same basis job is running"}})
def start_basis(wing: str, body: BasisRequest, response: Response, svc: Service = Depends(service)) -> dict[str, Any]:
    """Start a basis job (LHS samples x modal analyses -> PCA basis; a wing without design variables: its own
    modes)."""
    wid, w = wing_or_404(svc, wing)
    if getattr(w, "structure", True) is None:
        raise invalid("wing", f"wing {w.name!r} is planform-only (no built-in structure): it has no design space "
                              "to sample; its modes come from outside (POST /modes)")
    s = svc.settings
    if body.samples > s.max_samples:
        raise invalid("samples", f"must be <= {s.max_samples}, got {body.samples}")
    if body.modes > s.max_modes:
        raise invalid("modes", f"must be <= {s.max_modes}, got {body.modes}")
    params = body.model_dump()
    key = content_hash("basis", wid, params)
    active = svc.store.jobs.find_active(key)
    if active is not None:
        response.status_code = 200
        return {"job_id": active["id"], "existing": True}
    return {"job_id": submit(svc.store, svc.celery, "basis", params, wing_id=wid, key=key)}


@router.put("/wings/{wing}/active-basis", dependencies=[Depends(require_key)],
            responses={**WRITE, **WING, **ok(ActiveBasisOut, "the active basis")})
def set_active_basis(wing: str, body: ActiveBasis, svc: Service = Depends(service)) -> dict[str, Any]:
    """Make one of the wing's bases the active one (what evaluations and trainings use unless told otherwise)."""
    wid, _ = wing_or_404(svc, wing)
    bid = resolve_basis_id(svc.store, wid, body.basis_id)
    svc.store.wings.set_active_basis(wid, bid)
    return {"wing_id": wid, "active_basis_id": bid}


@router.get("/wings/{wing}/bases", responses={**WING, **ok(list[BasisOut], "bases, newest first")})
def list_bases(wing: str, svc: Service = Depends(service)) -> list[dict[str, Any]]:
    """Bases of a wing, newest first: parameters, size m, MAC table (worst MAC by m, per-sample MACs)."""
    wid, _ = wing_or_404(svc, wing)
    out = []
    for b in svc.store.bases.of_wing(wid):
        sm = b["summary"]
        n_modes = int(sm.get("n_modes") or b["params"].get("modes") or 1)
        table = sm.get("mac_table")
        if isinstance(table, list) and n_modes and len(table) % n_modes == 0:
            b["mac_by_sample"] = [table[i:i + n_modes] for i in range(0, len(table), n_modes)]
        out.append(b)
    return out


def _train_options(solver: str, options: dict[str, Any], n_shapes: int | None = None) -> dict[str, Any]:
    """Validate extra training keyword settings of ``solver`` (names and JSON scalar values; for the TSD also
    the grid against ``n_shapes`` basis shapes)."""
    if not options and solver != "tsd":
        return {}
    allowed = allowed_options(solver)
    for k, v in options.items():
        if k not in allowed:
            raise invalid(f"options.{k}", f"not a training setting of solver {solver!r}; allowed: {sorted(allowed)}")
        if isinstance(v, float) and not math.isfinite(v):
            raise invalid(f"options.{k}", "must be finite")
        if isinstance(v, list):  # a table (e.g. k_values of the dlm): finite numbers only
            if not all(isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for x in v):
                raise invalid(f"options.{k}", "a list must hold finite numbers only")
        elif not isinstance(v, bool | int | float | str | type(None)):
            raise invalid(f"options.{k}", "must be a number, a list of numbers, a string, a boolean or null")
    try:
        check_options(solver, options, n_shapes)
    except ServiceError as exc:
        raise invalid(exc.field or "options", exc.reason) from None
    return dict(sorted(options.items()))


@router.post("/wings/{wing}/roms", status_code=202, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **ok(RomJob | RomJobs, "every model exists or is training: no new job"),
                        **ok(RomJob | RomJobs, "training jobs queued (RomJob for mach, RomJobs for machs)", 202)})
def start_training(wing: str, body: RomRequest, response: Response, svc: Service = Depends(service)) -> dict[str, Any]:
    """Train ROMs: one job per Mach; an identical request returns the existing model or the running job."""
    wid, wdef = wing_or_404(svc, wing)
    no_nul(body.options, "options")
    basis_id = resolve_basis_id(svc.store, wid, body.basis_id)
    bad = [m for m in ([body.mach] if body.mach is not None else body.machs or []) if m >= 1.0]
    if bad:
        what = "TSD solver (until supersonic free streams are supported)" if body.solver == "tsd" else \
            f"linear {body.solver.upper()}"
        raise invalid("mach" if body.mach is not None else "machs",
                      f"the {what} is subsonic only (Mach < 1), got {bad[0]}")
    if body.solver == "tsd":
        from romams_core.aero.tsd.solver import MIN_MACH

        bad = [m for m in ([body.mach] if body.mach is not None else body.machs or []) if m < MIN_MACH]
        if bad:
            raise invalid("mach" if body.mach is not None else "machs",
                          f"the TSD solver needs Mach >= {MIN_MACH} (its factored scheme is unstable below; use "
                          f"the dlm there), got {bad[0]}")
    if not available(body.solver):
        raise invalid("solver", f"the solver {body.solver!r} is not available on this server")
    n_shapes = _basis_or_404(svc, basis_id).n_basis if body.solver == "tsd" else None
    options = _train_options(body.solver, body.options, n_shapes)
    identity = rom_identity(body.solver, body.na, body.nb, options, wing=wdef)
    machs = [float(body.mach)] if body.mach is not None else [float(m) for m in body.machs or []]
    if len({round(m, 6) for m in machs}) != len(machs):
        raise invalid("machs", "contains duplicates")
    items: list[dict[str, Any]] = []
    created = False
    for mach in machs:
        key = rom_key(wid, basis_id, mach, identity)
        rom_id = svc.store.roms.find_id(wid, basis_id, mach, identity)
        if rom_id is not None:
            row = next((r for r in svc.store.roms.of_wing(wid, basis_id) if r["id"] == rom_id), {})
            items.append({"mach": mach, "job_id": row.get("job_id"), "rom_id": rom_id, "existing": True})
            continue
        active = svc.store.jobs.find_active(key)
        if active is not None:
            items.append({"mach": mach, "job_id": active["id"], "rom_id": None, "existing": True})
            continue
        params = {"mach": mach, "basis_id": basis_id, "identity": identity, **identity}
        items.append({"mach": mach, "rom_id": None, "existing": False,
                      "job_id": submit(svc.store, svc.celery, "training", params, wing_id=wid, key=key)})
        created = True
    response.status_code = 202 if created else 200
    if body.mach is not None:
        return items[0]
    return {"job_ids": [i["job_id"] for i in items], "items": items}


@router.get("/wings/{wing}/roms", responses={**WING, **ok(list[RomOut], "trained ROMs, by Mach")})
def list_roms(wing: str, basis_id: int | None = Query(default=None, ge=ID_MIN, le=ID_MAX),
              svc: Service = Depends(service)) -> list[dict[str, Any]]:
    """Trained ROMs of a wing: Mach, solver settings, validation fit error."""
    wid, _ = wing_or_404(svc, wing)
    return svc.store.roms.of_wing(wid, basis_id)


def _basis_or_404(svc: Service, basis_id: int) -> Any:
    """Stored Basis or a 404 problem."""
    try:
        return svc.store.bases.load(basis_id)
    except KeyError as exc:
        raise Problem(404, f"basis_id: no basis {basis_id}", "basis_id") from exc


def _basis_wing(svc: Service, basis_id: int) -> Any:
    """WingDefinition the basis belongs to."""
    wid = svc.store.bases.wing_id(basis_id)
    if wid is None:
        raise Problem(404, f"basis_id: no basis {basis_id}", "basis_id")
    return wing_or_404(svc, str(wid))[1]


def _mean_flow_or_404(svc: Service, rom_id: int) -> dict[str, Any]:
    """The stored TSD mean flow of a ROM, or a 404 problem (no such ROM, or a ROM of a linear solver)."""
    try:
        rom = svc.store.roms.load(rom_id)
    except KeyError as exc:
        raise Problem(404, f"rom_id: no ROM {rom_id}", "rom_id") from exc
    mean_flow = getattr(rom, "mean_flow", None)
    if not mean_flow:
        raise Problem(404, f"rom_id: ROM {rom_id} ({rom.solver}) has no mean flow; only TSD ROMs do", "rom_id")
    return dict(mean_flow)


@router.get("/roms/{rom_id}/mean-flow", responses={**FOUND, **ok(MeanFlow, "the TSD mean flow")})
def rom_mean_flow(rom_id: int, svc: Service = Depends(service)) -> dict[str, Any]:
    """Steady mean flow of a TSD ROM: linear surface Cp (upper/lower) on the wing nodes (x/c by span fraction),
    the sonic Cp*, and the pseudo-time convergence (steps, converged, residual history)."""
    return _mean_flow_or_404(svc, rom_id)


@router.get("/roms/{rom_id}/mean-flow.{fmt}", response_class=Response,
            responses={**FOUND, **IMAGE, **NOT_MODIFIED})
def rom_mean_flow_plot(request: Request, rom_id: int, fmt: Literal["png", "svg"],
                       svc: Service = Depends(service)) -> Response:
    """Upper/lower surface Cp of a TSD ROM's mean flow at four span stations, sonic Cp marked (PNG or SVG)."""
    from romams.plots.transonic import plot_mean_flow_cp

    mean_flow = _mean_flow_or_404(svc, rom_id)
    return plot_response(request, fmt, ("mean-flow", mean_flow), lambda: plot_mean_flow_cp(mean_flow))


@router.get("/bases/{basis_id}/shapes.{fmt}", response_class=Response, responses={**FOUND, **IMAGE, **NOT_MODIFIED})
def basis_shapes_plot(request: Request, basis_id: int, fmt: Literal["png", "svg"],
                      svc: Service = Depends(service)) -> Response:
    """Plot of the basis shapes on the planform, axes in m, root/tip and flow direction (PNG or SVG)."""
    from romams.plots.basis import plot_basis_shapes
    from romams_core.mesh import standard_mesh

    basis = _basis_or_404(svc, basis_id)
    mesh = standard_mesh(_basis_wing(svc, basis_id).planform)
    return plot_response(request, fmt, ("basis-shapes", mesh.x, mesh.y, basis.shapes, basis.singular_values),
                         lambda: plot_basis_shapes(mesh, basis.shapes, basis.singular_values))


@router.get("/bases/{basis_id}/mac.{fmt}", response_class=Response, responses={**FOUND, **IMAGE, **NOT_MODIFIED})
def basis_mac_plot(request: Request, basis_id: int, fmt: Literal["png", "svg"],
                   svc: Service = Depends(service)) -> Response:
    """log10(1 - worst snapshot MAC) against the number of basis shapes, threshold lines (PNG or SVG)."""
    from romams.plots.basis import plot_mac_vs_basis_size

    b = _basis_or_404(svc, basis_id)
    parts = ("basis-mac", b.min_mac_by_m, b.mac_threshold, b.n_basis)
    return plot_response(request, fmt, parts, lambda: plot_mac_vs_basis_size(
        b.min_mac_by_m, b.mac_threshold, b.n_basis, labels=["worst sample mode"]))
