"""Response models of the HTTP API (OpenAPI documentation of the JSON the routes send, with an example each).

Routes declare them with :func:`ok` (``responses=``), not ``response_model=``: the route's dict is sent as it is
(no filtering, no second validation pass), so every key the model lists is a contract and ``extra="allow"`` keeps
the other keys documented as possible. The request models are in api.schemas.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from api.schemas import FlutterSummary
from romams.persistence import JobStatus

NOW = "2026-12-02T10:00:00+00:00"


def example(**values: Any) -> ConfigDict:
    """Model config: extra keys allowed, and ``values`` as the schema's example."""
    return ConfigDict(extra="allow", json_schema_extra={"examples": [values]})


def ok(model: Any, description: str, status: int = 200) -> dict[int | str, dict[str, Any]]:
    """``responses=`` entry of a JSON result documented by ``model``."""
    return {status: {"model": model, "description": description}}


class Health(BaseModel):
    """Liveness: the service version and the database dialect it reached."""

    model_config = example(status="ok", version="0.9.0", database="postgresql")

    status: str = Field(description='"ok"')
    version: str
    database: str = Field(description="dialect of the database that answered SELECT 1 (sqlite, postgresql)")


class DesignVariable(BaseModel):
    """One design variable of a wing: bounds and unit."""

    name: str
    lower: float
    upper: float
    unit: str | None = None
    description: str | None = None


class WingSummary(BaseModel):
    """A stored wing in the list: its bases and trained Mach numbers."""

    model_config = example(id=1, name="cropped-delta", created_at=NOW, latest_basis_id=3, active_basis_id=3,
                           trained_machs=[0.79, 0.87])

    id: int
    name: str
    created_at: str | None
    latest_basis_id: int | None
    active_basis_id: int | None
    trained_machs: list[float]


class WingDetail(WingSummary):
    """One wing with its design variables and stored definition."""

    model_config = example(id=1, name="cropped-delta", created_at=NOW, latest_basis_id=3, active_basis_id=3,
                           trained_machs=[0.79], has_baseline=True, definition={"name": "cropped-delta"},
                           design_variables=[{"name": "t_skin_root", "lower": 0.0008, "upper": 0.003, "unit": "m",
                                              "description": "skin thickness at the root"}])

    name: str | None  # type: ignore[assignment]
    design_variables: list[DesignVariable]
    has_baseline: bool
    definition: dict[str, Any] | None = Field(description="WingDefinition.to_dict() JSON (GET /schemas/wing)")


class JsonSchemaDocument(BaseModel):
    """A JSON Schema document (draft 2020-12)."""

    model_config = example(**{"$schema": "https://json-schema.org/draft/2020-12/schema", "title": "WingDefinition",
                              "type": "object", "properties": {"name": {"type": "string"}}})

    type: str | None = None
    title: str | None = None
    properties: dict[str, Any] | None = None


class ActiveBasisOut(BaseModel):
    """The wing's active basis after the change."""

    model_config = example(wing_id=1, active_basis_id=3)

    wing_id: int
    active_basis_id: int


class BasisOut(BaseModel):
    """A stored basis: LHS parameters, size, MAC table (per sample: the MAC of each mode)."""

    model_config = example(id=3, wing_id=1, params={"samples": 25, "modes": 4, "seed": 0}, n_basis=8,
                           summary={"n_modes": 4, "min_mac": 0.99993}, job_id="6f1c...", created_at=NOW,
                           mac_by_sample=[[0.99998, 0.99995, 0.99993, 0.99999]])

    id: int
    wing_id: int
    params: dict[str, Any]
    n_basis: int = Field(description="number of basis shapes m")
    summary: dict[str, Any] = Field(description="basis statistics: n_modes, mac_table, worst MAC by m, ...")
    job_id: str | None
    created_at: str | None
    mac_by_sample: list[list[float]] | None = Field(default=None, description="MAC of each mode, per LHS sample")


class RomOut(BaseModel):
    """A trained ROM: Mach, solver, its settings and validation summary."""

    model_config = example(id=5, wing_id=1, basis_id=3, mach=0.79, solver="dlm", params={"na": 0, "nb": 0},
                           summary={"fit_error": 0.004}, job_id="a3e9...", created_at=NOW)

    id: int
    wing_id: int
    basis_id: int
    mach: float
    solver: str
    params: dict[str, Any]
    summary: dict[str, Any]
    job_id: str | None
    created_at: str | None


class RomJob(BaseModel):
    """The ROM of one Mach: its training job, or the existing model (``existing``: no new job)."""

    model_config = example(mach=0.79, job_id="a3e9...", rom_id=None, existing=False)

    mach: float
    job_id: str | None
    rom_id: int | None
    existing: bool


class RomJobs(BaseModel):
    """ROM training of several Mach numbers (``machs``): one entry per Mach."""

    model_config = example(job_ids=["a3e9...", "b71d..."], items=[
        {"mach": 0.79, "job_id": "a3e9...", "rom_id": None, "existing": False},
        {"mach": 0.87, "job_id": "b71d...", "rom_id": 6, "existing": True}])

    job_ids: list[str | None]
    items: list[RomJob]


class MeanFlow(BaseModel):
    """Steady TSD mean flow: surface Cp on the wing nodes (x/c by span fraction eta), sonic Cp*, convergence."""

    model_config = example(mach=0.87, x_over_c=[[0.0, 0.5, 1.0]], eta=[[0.5, 0.5, 0.5]],
                           cp_upper=[[-0.2, -0.6, 0.1]], cp_lower=[[0.2, 0.1, 0.0]], cp_star=-0.2,
                           steady_steps=400, steady_converged=True, dt=0.02, steady_seconds=3.1,
                           residual_history=[1.0, 1e-3, 1e-6], far_field="wake")

    mach: float
    x_over_c: list[Any] = Field(description="chordwise position x/c of each wing node")
    eta: list[Any] = Field(description="span fraction of each wing node")
    cp_upper: list[Any]
    cp_lower: list[Any]
    cp_star: float = Field(description="sonic pressure coefficient")
    steady_steps: int
    steady_converged: bool
    residual_history: list[float | None]
    far_field: str | None = Field(default=None, description="the outer faces the TSD solved with: 'wake' (the wake's "
                                  "steady potential on them) or 'plain' (slip walls in steady flow); absent in ROMs "
                                  "trained before 2026-12-05, which had the plain faces")
    grid: dict[str, Any] | None = Field(default=None, description="the TSD grid it was solved on (cell counts and "
                                        "extents); a supercritical mean flow trains on the requested grid x "
                                        "supercritical_refine (docs/transonic.md 7.21); absent in ROMs trained "
                                        "before 2026-12-07")


class JobAccepted(BaseModel):
    """A job queued or running (202; the Location header points to GET /jobs/{job_id})."""

    model_config = example(job_id="c0ffee00-1234", status="queued", n=200)

    job_id: str
    status: JobStatus
    n: int | None = Field(default=None, description="designs in the batch")


class BatchResults(BaseModel):
    """A finished batch: one flutter summary per design, in request order."""

    model_config = example(job_id="c0ffee00-1234", run_id=1,
                           results=FlutterSummary.model_json_schema()["examples"][:1])

    results: list[FlutterSummary]
    job_id: str
    run_id: int | None = None


class EvaluationSummary(BaseModel):
    """A stored evaluation in the list (its flutter summary)."""

    model_config = example(id=7, wing_id=1, basis_id=3, method="rom-ams", created_at=NOW,
                           summary={"wing": "cropped-delta", "min_mac": 0.9999, "constraints_ok": True})

    id: int
    wing_id: int
    basis_id: int | None
    method: str
    summary: dict[str, Any] = Field(description="the flutter summary (FlutterSummary keys)")
    created_at: str | None


class EvaluationOut(EvaluationSummary):
    """A stored evaluation: its request, summary and content hash."""

    model_config = example(id=7, wing_id=1, basis_id=3, method="rom-ams", created_at=NOW, content_hash="9b2e...",
                           request={"design": {"t_skin_root": 0.002}}, summary={"wing": "cropped-delta"})

    request: dict[str, Any]
    content_hash: str | None


class VgBranches(BaseModel):
    """V-g and V-omega data of one Mach: per sweep point, per branch."""

    model_config = ConfigDict(extra="allow")

    mach: float
    sweep: str
    v_m_s: list[float | None] = Field(description="true airspeed of each sweep point (m/s)")
    q_pa: list[float | None] = Field(description="dynamic pressure (Pa)")
    rho: list[float | None] = Field(description="density (kg/m^3)")
    altitude_m: list[float | None] | None = None
    g: list[list[float | None]] = Field(description="damping g per sweep point and branch")
    omega_rad_s: list[list[float | None]] = Field(description="frequency per sweep point and branch (rad/s)")
    v_flutter_m_s: float | None
    omega_flutter_rad_s: float | None
    flutter_mode: int | None


class VgData(BaseModel):
    """V-g data of a stored evaluation, every Mach."""

    model_config = example(evaluation_id=7, machs=[{
        "mach": 0.79, "sweep": "constant-speed", "v_m_s": [236.0, 236.0], "q_pa": [0.0, 5000.0],
        "rho": [0.0, 0.18], "altitude_m": None, "g": [[-0.01, -0.02], [0.0, -0.05]],
        "omega_rad_s": [[60.0, 150.0], [62.0, 148.0]], "v_flutter_m_s": 236.0, "omega_flutter_rad_s": 101.0,
        "flutter_mode": 1}])

    evaluation_id: int
    machs: list[VgBranches]


class ModesStored(BaseModel):
    """Stored external modes (use the id as ``modes_id`` in a flutter request)."""

    model_config = example(id=2, n_nodes=231, n_modes=6, frequencies_hz=[4.1, 11.8, 19.5, 27.0, 35.2, 44.9])

    id: int
    n_nodes: int
    n_modes: int
    frequencies_hz: list[float]
