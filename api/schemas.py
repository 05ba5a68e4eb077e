"""Pydantic request/response schemas of the HTTP API (JSON keys are part of the contract)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, FiniteFloat, model_validator

from romams.persistence import ID_MAX, ID_MIN, JobStatus
from romams.services.gaf_import import LABEL

Design = dict[str, FiniteFloat] | list[FiniteFloat]


def _no_nul(value: str) -> str:
    """A string without NUL characters (PostgreSQL text cannot hold them); nested JSON objects (a wing definition,
    training options) are checked by the routes (api.deps.no_nul), which name the field inside."""
    if "\x00" in value:
        raise ValueError("must not contain NUL characters")
    return value


#: text stored or looked up in the database: no NUL character
Text = Annotated[str, AfterValidator(_no_nul)]
#: id of a stored row: within the id columns' integer range (beyond it no row can exist, and PostgreSQL refuses it)
RowId = Annotated[int, Field(ge=ID_MIN, le=ID_MAX)]


class _Strict(BaseModel):
    """Unknown keys are errors (a typo must not be silently ignored), and types are strict: no string is taken
    for a number or a boolean (``"25"`` is not 25), no float for an integer; an integer is a valid float."""

    model_config = ConfigDict(extra="forbid", strict=True)


class WingCreate(_Strict):
    """A wing from a built-in template (optionally renamed) or from a full definition."""

    template: Text | None = Field(default=None, description='built-in template: "cropped-delta" or "goland"')
    name: Text | None = Field(default=None, min_length=1, max_length=200)
    definition: dict[str, Any] | None = Field(default=None, description="WingDefinition.to_dict() JSON (its JSON "
                                              "Schema: GET /schemas/wing)")

    @model_validator(mode="after")
    def _one_source(self) -> WingCreate:
        if (self.template is None) == (self.definition is None):
            raise ValueError("give exactly one of 'template' or 'definition'")
        return self


class Created(BaseModel):
    """Id of a created resource."""

    model_config = ConfigDict(json_schema_extra={"examples": [{"id": 1}]})

    id: int


class BasisRequest(_Strict):
    """Basis job settings: LHS samples, modes per structure, MAC threshold, cap, seed."""

    samples: int = Field(default=25, ge=2)
    modes: int = Field(default=4, ge=1)
    mac_threshold: float = Field(
        default=0.9999, gt=0.0, lt=1.0,
        description="every sample mode must fit with MAC >= this; the default 0.9999 (8 shapes on the cropped "
                    "delta) keeps ROM-AMS within 1 % of ROM-PMS in flutter speed; 0.98 does not")
    max_basis: int = Field(default=12, ge=1, le=100)
    seed: int = Field(default=0, ge=0, le=2**31 - 1)


class SnapshotBasisRequest(_Strict):
    """A basis from uploaded mode sets (POST /modes ids): the first ``modes`` modes of each set are the snapshots."""

    modes_ids: list[int] = Field(min_length=2, max_length=1000, description="ids of uploaded mode sets (POST /modes), "
                                 "one per design of your design space")
    modes: int = Field(default=4, ge=1, le=50, description="modes per set taken as snapshots (the lowest)")
    mac_threshold: float = Field(default=0.9999, gt=0.0, lt=1.0, description="every snapshot must fit with MAC >= this")
    max_basis: int = Field(default=12, ge=1, le=100)


class JobRef(BaseModel):
    """A submitted job."""

    model_config = ConfigDict(json_schema_extra={"examples": [{"job_id": "c0ffee00-1234", "existing": False}]})

    job_id: str
    existing: bool = False


class RomRequest(_Strict):
    """ROM training: one Mach (``mach``) or several (``machs``), solver and ARX orders (Mach 0: incompressible).

    ``solver``: "dlm" (default; doublet lattice, frequency domain, rational-function ROM), "uvlm" (time domain,
    ARX ROM; exact for incompressible flow, its phase error grows above M 0.5) or "tsd" (transonic small
    disturbance, nonlinear, 0 < M < 1: an ARX ROM about the steady transonic mean flow of the wing's section;
    minutes per Mach). ``na``/``nb`` are the ARX orders of a time-domain solver (ignored, stored as 0, for "dlm").
    """

    mach: FiniteFloat | None = Field(default=None, ge=0.0, lt=1.5)
    machs: list[FiniteFloat] | None = Field(default=None, min_length=1, max_length=20)
    solver: Literal["dlm", "uvlm", "tsd"] = "dlm"
    na: int | None = Field(default=None, ge=1, le=40, description="ARX output order (default: the solver's, 8 "
                           "for uvlm and tsd)")
    nb: int | None = Field(default=None, ge=1, le=40, description="ARX input order (default: the solver's)")
    basis_id: RowId | None = None
    options: dict[str, Any] = Field(default_factory=dict, description="extra keyword settings of the solver's "
                                    "training function (train_rfa_rom for dlm, train_rom for uvlm, "
                                    "train_tsd_rom for tsd)")

    @model_validator(mode="after")
    def _one_mach_field(self) -> RomRequest:
        if (self.mach is None) == (self.machs is None):
            raise ValueError("give exactly one of 'mach' or 'machs'")
        for m in self.machs or []:
            if not 0.0 <= m < 1.5:
                raise ValueError(f"machs: {m} is outside [0, 1.5)")
        return self


class ModesIn(_Strict):
    """External modes: node coordinates (m), one shape per mode (P values each), frequencies, masses."""

    nodes: list[list[FiniteFloat]] = Field(min_length=3)
    shapes: list[list[FiniteFloat]] = Field(min_length=1)
    frequencies_hz: list[FiniteFloat] = Field(min_length=1)
    generalized_masses: list[FiniteFloat] | None = None
    mass_kg: FiniteFloat | None = None


class FlightFields(_Strict):
    """Flight condition of a flutter search (absent fields take the service's defaults)."""

    sweep: Literal["constant-speed", "constant-density", "matched"] | None = Field(
        default=None, description="constant-speed (default: V = M a at altitude_ref_m, density swept), "
        "constant-density (V swept at the reference density; always used at Mach 0), matched (altitude swept, "
        "V = M a(h))")
    altitude_ref_m: FiniteFloat | None = Field(default=None, ge=0.0, le=20_000.0,
                                               description="ISA reference altitude (default 10000 m)")
    rho_ref: FiniteFloat | None = Field(default=None, gt=0.0, description="reference density (kg/m^3), overrides "
                                                                          "the ISA density at altitude_ref_m")
    v_max_m_s: FiniteFloat | None = Field(default=None, gt=0.0, description="constant-density sweep: top speed "
                                          "(m/s; default 3 M a_ref, or from the structure at Mach 0)")
    q_max_pa: FiniteFloat | None = Field(default=None, gt=0.0, description="constant-speed sweep: top dynamic "
                                                                           "pressure (Pa; default 4 q_ref)")
    projection_correction: Literal["auto", "none", "dlm"] | None = Field(
        default=None, description="auto (default: dlm on TSD ROMs, none otherwise) | none | dlm: add the part of the "
        "modes outside the basis span by the doublet-lattice method (ROM-AMS; docs/transonic.md 7.12)")


SOLVER_CHOICE = ("aerodynamic solver whose ROMs to use: dlm, uvlm, tsd, or external:<label> for an imported GAF table "
                 "(ROMs of several solvers may be trained for one Mach; default: the dlm ROM where one is trained, "
                 "else the newest ROM of that Mach)")
#: a solver whose ROMs an evaluation uses: a built-in one or an imported table's
EvalSolver = Annotated[str, Field(pattern=f"^(dlm|uvlm|tsd|external:{LABEL.pattern})$", max_length=49)]


class FlutterRequest(FlightFields):
    """One structure: design variables (by name or as a vector), or external modes, or an uploaded modes id."""

    design: Design | None = None
    modes: ModesIn | None = None
    modes_id: RowId | None = None
    machs: list[FiniteFloat] | None = Field(default=None, min_length=1, max_length=20)
    method: Literal["rom-ams", "rom-pms"] = Field(
        default="rom-ams",
        description="rom-ams: the trained basis ROMs (fast, synchronous). rom-pms: the reference -- a ROM "
        "trained on this structure's own modes at every Mach with the trained ROMs' solver settings; "
        "a training-queue job (202 with job_id).")
    basis_id: RowId | None = Field(default=None, description="basis to use (default: the wing's active basis)")
    solver: EvalSolver | None = Field(default=None, description=SOLVER_CHOICE)
    store: bool = Field(default=True, description="store the evaluation (V-g data, plots)")

    @model_validator(mode="after")
    def _one_structure(self) -> FlutterRequest:
        if sum(x is not None for x in (self.design, self.modes, self.modes_id)) > 1:
            raise ValueError("give at most one of 'design', 'modes' or 'modes_id'")
        return self


class BatchRequest(FlightFields):
    """A batch of designs evaluated at the given (default: all trained) Mach numbers."""

    designs: list[Design] = Field(min_length=1)
    machs: list[FiniteFloat] | None = Field(default=None, min_length=1, max_length=20)
    method: Literal["rom-ams"] = "rom-ams"
    basis_id: RowId | None = Field(default=None, description="basis to use (default: the wing's active basis)")
    solver: EvalSolver | None = Field(default=None, description=SOLVER_CHOICE)
    run_id: RowId | None = Field(default=None, description="run (POST /api/v1/runs) whose evaluations these designs "
                                 "are: each is stored compactly as an evaluation of the run")
    keep_vg: bool = Field(default=False, description="with run_id: keep the V-g data of every design of this batch "
                          "(by default only a run's new best designs keep them)")


class ActiveBasis(_Strict):
    """The basis that evaluations of a wing use by default."""

    basis_id: RowId


class MachResult(BaseModel):
    """Flutter point at one Mach number (None where no flutter was found in the sweep range)."""

    model_config = ConfigDict(extra="allow")

    mach: float
    flutter_found: bool
    v_flutter_m_s: float | None = Field(description="TRUE airspeed at the flutter point (m/s) of the sweep used "
                                                    "(for constant-speed: M a_ref); same as v_true_m_s")
    v_true_m_s: float | None = Field(description="true airspeed at the flutter point (m/s)")
    v_eas_m_s: float | None = Field(description="equivalent airspeed sqrt(2 q_f / rho_0), rho_0 = ISA sea level")
    q_flutter_pa: float | None = Field(description="dynamic pressure at the flutter point (Pa)")
    omega_flutter_rad_s: float | None = Field(description="flutter frequency (rad/s)")
    flutter_mode: int | None = Field(description="1-based structural mode the flutter branch starts from")
    sdoff: bool
    outside_band: bool = Field(False, description="the flutter point's reduced frequency is above the band the ROM "
                               "was identified in: not a prediction (the message says so)")
    unstable_above_band_v_m_s: float | None = Field(
        None, description="constant-density sweep: highest true airspeed (m/s) below the flutter point at which a "
        "branch was unstable with its reduced frequency above the ROM's band, an instability the ROM shows outside "
        "its validity and that is not counted as flutter (docs/flutter.md 9.10)")
    sweep: str = Field(description="the sweep used at this Mach (constant-density at Mach 0)")
    altitude_ref_m: float | None = Field(description="ISA reference altitude (m) of rho_ref and a_ref")
    rho_ref_kg_m3: float | None = Field(description="reference density (kg/m^3)")


class FlutterSummary(BaseModel):
    """Flutter evaluation of one structure: the same keys from the API, ``romams flutter --json`` and in-process."""

    model_config = ConfigDict(extra="allow", json_schema_extra={"examples": [{
        "wing": "cropped-delta", "wing_id": 1, "method": "rom-ams", "basis_id": 3, "n_basis": 8,
        "flight_condition": {"sweep": "constant-speed", "altitude_ref_m": 10000.0}, "mass_kg": 0.1893,
        "frequencies_hz": [13.9, 45.1, 60.2, 98.7], "mac": [0.99999, 0.99998, 0.99996, 0.99993], "min_mac": 0.99993,
        "mac_ok": True, "fit_error_estimate_pct": 0.2, "warning": None, "constraints_ok": True, "envelope_ok": True,
        "results": [{"mach": 0.79, "flutter_found": True, "v_flutter_m_s": 236.0, "v_true_m_s": 236.0,
                     "v_eas_m_s": 121.0, "q_flutter_pa": 9000.0, "omega_flutter_rad_s": 210.0, "flutter_mode": 1,
                     "sdoff": False, "sweep": "constant-speed", "altitude_ref_m": 10000.0, "rho_ref_kg_m3": 0.4135}],
        "evaluation_id": 7, "job_id": "c0ffee00-1234"}]})

    wing: str
    method: str
    basis_id: int
    flight_condition: dict[str, Any]
    mass_kg: float | None
    frequencies_hz: list[float]
    mac: list[float]
    min_mac: float
    mac_ok: bool
    fit_error_estimate_pct: float = Field(description="estimated ROM-AMS flutter-speed error from the mode fit (%)")
    warning: str | None = Field(description="set when the structure fits the basis worse than it was validated for")
    results: list[MachResult]
    constraints_ok: bool


class JobOut(BaseModel):
    """A job as the API shows it."""

    model_config = ConfigDict(extra="allow", json_schema_extra={"examples": [{
        "id": "c0ffee00-1234", "kind": "basis", "status": "running", "progress": 0.4, "message": "modal analyses 10/25",
        "result": None, "error": None, "params": {"samples": 25}, "wing_id": 1, "parent_id": None, "deliveries": 1,
        "worker": "celery@host", "run_id": None, "traceback": None, "events": [["2026-12-02T10:00:00+00:00", 0.4,
        "modal analyses 10/25"]], "created_at": "2026-12-02T10:00:00+00:00", "started_at": "2026-12-02T10:00:00+00:00",
        "finished_at": None, "updated_at": "2026-12-02T10:00:01+00:00"}]})

    id: str
    kind: str
    status: JobStatus
    progress: float
    message: str
    result: Any = None
    error: str | None = None
    created_at: str | None = None
    started_at: str | None = None
    finished_at: str | None = None
    wing_id: int | None = None
    parent_id: str | None = None
    deliveries: int = 0
    worker: str | None = None
    params: dict[str, Any] = Field(default_factory=dict)
    run_id: int | None = Field(default=None, description="the run a batch belongs to")
    traceback: str | None = Field(default=None, description="Python traceback of a failure")
    events: list[list[Any]] = Field(default_factory=list, description="progress history: [ISO time, progress 0..1, "
                                    "message], the last 50 messages")


class RunCreate(_Strict):
    """A run (study): the evaluations of one optimization or UQ campaign, and its feasibility rule."""

    name: Text = Field(min_length=1, max_length=200, description="a name for people (need not be unique)")
    wing: int | Text | None = Field(default=None, description="the wing (id or name) whose designs the run evaluates")
    mu_kg: FiniteFloat | None = Field(default=None, gt=0.0, description="penalty of an infeasible design (kg): "
                                      "objective = mass + mu_kg (default 10)")
    mac_threshold: FiniteFloat | None = Field(default=None, gt=0.0, le=1.0,
                                              description="smallest acceptable mode-fit MAC (default 0.98)")
    envelope_tol_m: FiniteFloat | None = Field(default=None, ge=0.0, description="a safe altitude up to this much "
                                               "above the baseline's still passes (m, default 0.01)")
    penalty: Literal["binary", "graded"] | None = Field(
        default=None, description="C of objective = mass + mu_kg C for an infeasible design: 'binary' (default, the "
        "paper's: C = 1) or 'graded' (C = 1 + envelope excess in km + MAC deficit / 0.02 + number of SDOFF Machs, "
        "as the client's FlutterProblem(penalty='graded'))")


class RunEvaluationOut(BaseModel):
    """One evaluated design of a run (compact)."""

    model_config = ConfigDict(extra="allow")

    id: int
    job_id: str | None = Field(description="the batch job that evaluated it")
    x: list[float] = Field(description="design vector, in the wing's variable order")
    mass_kg: float | None
    objective: float | None = Field(description="mass + mu_kg when infeasible (kg)")
    feasible: bool
    envelope_ok: bool | None
    min_mac: float | None
    flutter: list[list[Any]] = Field(description="per Mach: [mach, v_eas_m_s, frequency_hz, flutter_mode, "
                                                 "safe_altitude_m, benchmark_safe_altitude_m]")
    error: str | None = Field(description="why the design could not be evaluated")
    evaluation_id: int | None = Field(description="stored evaluation with the V-g data, when kept")


class RunSummary(BaseModel):
    """A run with its counts, best design so far and status."""

    model_config = ConfigDict(extra="allow", json_schema_extra={"examples": [{
        "id": 1, "name": "DE cropped delta", "wing_id": 1, "created_at": "2026-12-02T10:00:00Z",
        "settings": {"mu_kg": 10.0, "mac_threshold": 0.98, "envelope_tol_m": 0.01}, "n_evaluations": 120,
        "n_feasible": 70, "n_infeasible": 50, "n_failed": 0, "n_with_vg": 4, "payload_bytes": 28200,
        "bytes_per_design": 235.0, "best": None, "best_objective": 0.1893, "status": "running", "active_jobs": 2}]})

    id: int
    name: str
    wing_id: int | None
    settings: dict[str, Any]
    created_at: str | None
    n_evaluations: int
    n_feasible: int
    n_infeasible: int
    n_failed: int
    n_with_vg: int = Field(description="evaluations whose V-g data are kept")
    payload_bytes: int = Field(description="stored bytes of the design vectors, flutter rows and error texts")
    bytes_per_design: float | None
    best: RunEvaluationOut | None = Field(description="best so far: feasible first, then the lowest objective")
    best_objective: float | None
    status: Literal["empty", "running", "idle"] = Field(description="running while a batch is queued or running")
    active_jobs: int


class RunEvaluations(BaseModel):
    """A page of a run's evaluations (poll with after_id = last_id)."""

    model_config = ConfigDict(json_schema_extra={"examples": [{
        "run_id": 1, "flutter_fields": ["mach", "v_eas_m_s", "frequency_hz", "flutter_mode", "safe_altitude_m",
                                        "benchmark_safe_altitude_m"],
        "evaluations": [{"id": 41, "job_id": "c0ffee00-1234", "x": [0.002, 0.0015], "mass_kg": 0.1893,
                         "objective": 0.1893, "feasible": True, "envelope_ok": True, "min_mac": 0.9999,
                         "flutter": [[0.79, 121.0, 33.4, 1, 10500.0, 10000.0]], "error": None,
                         "evaluation_id": None}], "last_id": 41}]})

    run_id: int
    flutter_fields: list[str]
    evaluations: list[RunEvaluationOut]
    last_id: int
