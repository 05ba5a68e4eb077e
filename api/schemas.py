"""Pydantic request/response schemas of the HTTP API (JSON keys are part of the contract)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, FiniteFloat, model_validator

from romams.persistence import JobStatus

Design = dict[str, FiniteFloat] | list[FiniteFloat]


class _Strict(BaseModel):
    """Unknown keys are errors (a typo must not be silently ignored)."""

    model_config = ConfigDict(extra="forbid")


class WingCreate(_Strict):
    """A wing from a built-in template (optionally renamed) or from a full definition."""

    template: str | None = Field(default=None, description='built-in template: "cropped-delta" or "goland"')
    name: str | None = Field(default=None, min_length=1, max_length=200)
    definition: dict[str, Any] | None = Field(default=None, description="WingDefinition.to_dict() JSON")

    @model_validator(mode="after")
    def _one_source(self) -> WingCreate:
        if (self.template is None) == (self.definition is None):
            raise ValueError("give exactly one of 'template' or 'definition'")
        return self


class Created(BaseModel):
    """Id of a created resource."""

    id: int


class BasisRequest(_Strict):
    """Basis job settings: LHS samples, modes per structure, MAC threshold, cap, seed."""

    samples: int = Field(default=25, ge=2)
    modes: int = Field(default=4, ge=1)
    mac_threshold: float = Field(default=0.98, gt=0.0, lt=1.0)
    max_basis: int = Field(default=12, ge=1, le=100)
    seed: int = Field(default=0, ge=0, le=2**31 - 1)


class JobRef(BaseModel):
    """A submitted job."""

    job_id: str
    existing: bool = False


class RomRequest(_Strict):
    """ROM training: one Mach (``mach``) or several (``machs``), solver and ARX orders."""

    mach: FiniteFloat | None = Field(default=None, gt=0.0, lt=1.5)
    machs: list[FiniteFloat] | None = Field(default=None, min_length=1, max_length=20)
    solver: Literal["uvlm", "tsd"] = "uvlm"
    na: int = Field(default=8, ge=1, le=40)
    nb: int = Field(default=8, ge=1, le=40)
    basis_id: int | None = None
    options: dict[str, Any] = Field(default_factory=dict, description="extra keyword settings of train_rom")

    @model_validator(mode="after")
    def _one_mach_field(self) -> RomRequest:
        if (self.mach is None) == (self.machs is None):
            raise ValueError("give exactly one of 'mach' or 'machs'")
        for m in self.machs or []:
            if not 0.0 < m < 1.5:
                raise ValueError(f"machs: {m} is outside (0, 1.5)")
        return self


class ModesIn(_Strict):
    """External modes: node coordinates (m), one shape per mode (P values each), frequencies, masses."""

    nodes: list[list[FiniteFloat]] = Field(min_length=3)
    shapes: list[list[FiniteFloat]] = Field(min_length=1)
    frequencies_hz: list[FiniteFloat] = Field(min_length=1)
    generalized_masses: list[FiniteFloat] | None = None
    mass_kg: FiniteFloat | None = None


class FlutterRequest(_Strict):
    """One structure: design variables (by name or as a vector), or external modes, or an uploaded modes id."""

    design: Design | None = None
    modes: ModesIn | None = None
    modes_id: int | None = None
    machs: list[FiniteFloat] | None = Field(default=None, min_length=1, max_length=20)
    method: Literal["rom-ams", "rom-pms"] = Field(
        default="rom-ams",
        description="rom-ams: the trained basis ROMs (fast, synchronous). rom-pms: the reference -- an ARX model "
        "identified on this structure's own modes at every Mach with the trained ROMs' solver settings; "
        "a training-queue job (202 with job_id).")
    basis_id: int | None = None
    store: bool = Field(default=True, description="store the evaluation (V-g data, plots)")

    @model_validator(mode="after")
    def _one_structure(self) -> FlutterRequest:
        if sum(x is not None for x in (self.design, self.modes, self.modes_id)) > 1:
            raise ValueError("give at most one of 'design', 'modes' or 'modes_id'")
        return self


class BatchRequest(_Strict):
    """A batch of designs evaluated at the given (default: all trained) Mach numbers."""

    designs: list[Design] = Field(min_length=1)
    machs: list[FiniteFloat] | None = Field(default=None, min_length=1, max_length=20)
    method: Literal["rom-ams"] = "rom-ams"
    basis_id: int | None = None


class JobOut(BaseModel):
    """A job as the API shows it."""

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
