"""The ROM-AMS paper's optimization case (section 3) regenerated in process, printed as ONE JSON object.

    python -m benchmarks.paper_case [--quick] [--solver dlm] [--generations G] [--plot DIR] [--processes P]
        [--anchor-k K ...] [--rom-dir DIR] --json

The cropped delta wing with the ECCENTRIC stiffener (``cropped_delta(beam_placement="eccentric")``, the paper's
Fig. 5: the beam glued to the plate's face), no server:

- basis: 25 LHS samples x 4 modes, every sample mode fitted with MAC >= 0.9999 (the size it needs is reported);
- ROMs of ``--solver`` (default dlm) on the basis at the paper's five Machs 0.79 .. 0.95;
- ``table5``: the two LHS samples whose mode shapes differ most (lowest mean mode-by-mode MAC: the paper's
  var1/var2 were chosen for large mode-shape differences), ROM-AMS vs ROM-PMS at M 0.87;
- the paper's DE (F 0.55, Np 30, CR 0.7, 150 generations; ``--quick``: 20) on the penalty objective of
  ``client.problem.FlutterProblem``, evaluated by the project's evaluation use case
  (``romams.services.evaluation``) through :class:`InProcessService`, and ``run_de`` of
  ``examples/optimize_cropped_delta.py``;
- ``table7``: fit MAC of the optimum's modes in the basis; ``table8``: ROM-AMS vs ROM-PMS (ROMs trained on the
  optimum's own modes) at the five Machs;
- ``fixed_mode_shapes``: the optimum's frequencies with the baseline plate's (mass-normalized) mode shapes at
  M 0.87 (the paper's Fig. 19/20), against the optimum's own modes;
- ``mass_reduction_pct`` against the baseline plate.

Speeds: ``v_*`` is sqrt(2 q_f / rho_ref) with rho_ref the ISA 10 km density of the sweep, the paper's measure
(its baseline's 2.488 psi at M 0.87 is 288 m/s so); ``v_eas_*`` the equivalent airspeed (sea-level density).
Progress goes to stderr.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, before numpy loads its BLAS

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import hashlib  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Mapping, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks.accuracy_rom_ams import anchor_options, anchor_value, pct_error  # noqa: E402
from benchmarks.run import load_example  # noqa: E402
from romams import serialize  # noqa: E402
from romams.pipeline import train_shape_sets  # noqa: E402
from romams.services.evaluation import (  # noqa: E402
    Models,
    evaluate_structure_summary,
    pms_summary,
    structure_modal,
)
from romams.services.flight import DEFAULT_CONDITION, FlightCondition  # noqa: E402
from romams.services.training import SOLVERS, rom_identity  # noqa: E402
from romams_core.basis import Basis, build_basis_for_wing, mac, snapshot  # noqa: E402
from romams_core.mesh import standard_mesh  # noqa: E402
from romams_core.projection_residual import PROJECTION_CORRECTIONS  # noqa: E402
from romams_core.training import TrainingError, with_minimal_realization  # noqa: E402
from romams_core.wing import WingDefinition, cropped_delta  # noqa: E402

EX = load_example("optimize_cropped_delta")  # the DE, the paper's settings and Table 6/8 values
TABLE5_MACH = 0.87
PSI_PA = 6894.757  # Pa per psi (the paper gives dynamic pressures in psi)
QUICK_GENERATIONS = 20
#: NRMSE tolerance a ROM is retrained with when the default refuses it (recorded in the JSON's training_notes)
RELAXED_NRMSE_TOL = 0.075
#: the paper's Table 5 (M 0.87): name -> (V ROM-AMS, V ROM-PMS m/s, omega ROM-AMS, omega ROM-PMS rad/s)
PAPER_TABLE5 = {"var1": (219.53, 214.68, 561.60, 550.05), "var2": (148.56, 150.47, 252.95, 254.03)}
PAPER_TABLE7 = (1.0, 0.9999, 0.9994, 0.9905)  # MAC of the optimum's modes 1-4 ("~1" for mode 1)
#: the paper's Table 8 flutter frequencies: Mach -> (omega ROM-AMS, omega ROM-PMS), rad/s
PAPER_TABLE8_OMEGA = {0.79: (228.13, 231.93), 0.83: (220.73, 224.14), 0.87: (214.94, 213.86),
                      0.91: (207.90, 200.87), 0.95: (198.87, 188.74)}
PAPER_FIXED_MODES = {"v_own_modes": 297.02, "v_fixed_modes": 207.4}  # m/s at M 0.87 (Fig. 19/20)


def log(msg: str) -> None:
    """Progress on stderr."""
    print(f"[paper-case] {msg}", file=sys.stderr, flush=True)


class Memo:
    """The use case's ``cache(key, load)``: the baseline evaluation is computed once per set of models."""

    def __init__(self) -> None:
        self.store: dict[Any, Any] = {}

    def __call__(self, key: Any, load: Any) -> Any:
        """Value of ``key``, loaded on first use."""
        if key not in self.store:
            self.store[key] = load()
        return self.store[key]


class InProcessService:
    """The part of ``client.RomamsClient`` that ``FlutterProblem`` calls, answered in process by the evaluation
    use case (the same JSON summaries as the API's, designs the structure model rejects as ``{"error": ...}``)."""

    def __init__(self, models: Models, cache: Memo | None = None, condition: FlightCondition = DEFAULT_CONDITION
                 ) -> None:
        self.models = models
        self.cache = cache or Memo()
        self.condition = condition

    def get_wing(self, _ref: Any) -> dict[str, Any]:
        """Id, design variables (bounds in their own units) and trained Machs of the wing."""
        dvs = [{"name": v.name, "lower": v.lower, "upper": v.upper} for v in self.models.wing.design_variables]
        return {"id": self.models.wing_id, "design_variables": dvs, "trained_machs": sorted(self.models.roms)}

    def evaluate(self, _wing: Any, design: Any, **_: Any) -> dict[str, Any]:
        """JSON summary of one design (None: the baseline) at every trained Mach."""
        d = None if design is None else np.asarray(design, dtype=float).tolist()
        return evaluate_structure_summary(self.models, design=d, cache=self.cache, condition=self.condition)[0]

    def evaluate_batch(self, wing: Any, designs: Any, **_: Any) -> list[dict[str, Any]]:
        """Summaries of designs [n, d] in order (per-design errors as the worker reports them)."""
        out = []
        for d in np.atleast_2d(np.asarray(designs, dtype=float)):
            try:
                out.append(self.evaluate(wing, d))
            except ValueError as exc:
                out.append({"error": str(exc)})
        return out


# ---- models ------------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Trainer:
    """How the case trains its ROMs: the Machs in ``processes`` processes; with ``rom_dir``, every ROM is kept
    there (keyed by mesh, shapes, Mach and ROM identity) and read back by a later run instead of retrained."""

    processes: int = 1
    rom_dir: Path | None = None
    notes: list[str] = dataclasses.field(default_factory=list)  # retrainings with a relaxed NRMSE tolerance

    def _path(self, mesh: Any, shapes: np.ndarray, mach: float, ident: Mapping[str, Any]) -> Path:
        """File of one ROM in ``rom_dir``."""
        assert self.rom_dir is not None
        h = hashlib.sha256(json.dumps(dict(ident), sort_keys=True, default=str).encode())
        for a in (np.asarray(mesh.x, dtype=float), np.asarray(mesh.y, dtype=float), np.asarray(shapes, dtype=float)):
            h.update(np.ascontiguousarray(a).tobytes())
        return self.rom_dir / f"rom-M{mach:g}-{h.hexdigest()[:20]}.npz"

    def roms(self, mesh: Any, shapes: np.ndarray, machs: Sequence[float], ident: Mapping[str, Any]) -> list[Any]:
        """ROMs of one shape set [N, k] at ``machs`` (in that order): stored ones read, the others trained."""
        paths = [self._path(mesh, shapes, float(m), ident) if self.rom_dir else None for m in machs]
        out: list[Any] = [_read_rom(p) if p is not None and p.exists() else None for p in paths]
        todo = [j for j, r in enumerate(out) if r is None]
        if todo:
            marks = [p.with_suffix(".refused") for p in paths if p is not None]  # a refusal is deterministic
            try:
                if len(todo) == 1 and marks and marks[todo[0]].exists():
                    raise TrainingError(marks[todo[0]].read_text())
                (trained,) = train_shape_sets(mesh, [shapes], [float(machs[j]) for j in todo], ident, self.processes)
            except TrainingError as exc:  # an own-mode (ROM-PMS) reference just above the tolerance: say so, relax
                if "nrmse_tol" in (ident.get("options") or {}) or "validation NRMSE" not in str(exc):
                    raise
                if len(todo) == 1 and marks:
                    marks[todo[0]].write_text(str(exc))
                relaxed = {**ident, "options": {**dict(ident.get("options") or {}), "nrmse_tol": RELAXED_NRMSE_TOL}}
                self.notes.append(f"{len(todo)} ROM(s) at M {[float(machs[j]) for j in todo]} of a {shapes.shape[1]}-"
                                  f"shape set: {exc}; retrained with nrmse_tol {RELAXED_NRMSE_TOL:g}")
                log(self.notes[-1])
                return self.roms(mesh, shapes, machs, relaxed)
            for j, rom in zip(todo, trained, strict=True):
                out[j] = rom
                if paths[j] is not None:
                    _write_rom(paths[j], rom)
        if len(todo) < len(out):
            log(f"{len(out) - len(todo)} of {len(out)} ROMs read from {self.rom_dir}")
        return out


def _write_rom(path: Path, rom: Any) -> None:
    """Store one ROM (the service's serializer: JSON meta + NPZ blob in one NPZ file)."""
    meta, blob = serialize.dumps(rom)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".part")
    np.savez(tmp, meta=np.array(json.dumps(meta)), blob=np.frombuffer(blob, dtype=np.uint8))
    Path(str(tmp) + ".npz").replace(path)


def _read_rom(path: Path) -> Any:
    """A ROM stored by :func:`_write_rom` (an ARX ROM stored with its full realization: with its minimal one)."""
    with np.load(path, allow_pickle=False) as f:
        return with_minimal_realization(serialize.loads(json.loads(str(f["meta"])), f["blob"].tobytes()))
def build_models(wing: WingDefinition, machs: Sequence[float], ident: Mapping[str, Any], samples: int = 25,
                 mac_threshold: float = 0.9999, max_basis: int = 12, seed: int = 0, trainer: Trainer = Trainer()
                 ) -> tuple[Models, dict[str, Any]]:
    """Basis (LHS samples x 4 modes) and one ROM per Mach on it (by ``trainer``); with the basis data and timings
    (s)."""
    mesh = standard_mesh(wing.planform)
    t0 = time.perf_counter()
    basis = build_basis_for_wing(wing, samples=samples, modes=4, mac_threshold=mac_threshold, max_basis=max_basis,
                                 seed=seed)
    t_basis = time.perf_counter() - t0
    log(f"basis: {basis.message} ({t_basis:.1f} s)")
    t0 = time.perf_counter()
    trained = trainer.roms(mesh, basis.shapes, machs, ident)
    roms = {float(m): (0, rom) for m, rom in zip(machs, trained, strict=True)}
    t_train = {"all": time.perf_counter() - t0}
    log(f"ROMs at {len(machs)} Machs in {trainer.processes} processes: {t_train['all']:.1f} s")
    info = {"samples": samples, "modes_per_sample": 4, "mac_threshold": mac_threshold, "max_basis": max_basis,
            "n_basis": int(basis.n_basis), "capped": bool(basis.capped), "worst_sample_mac": float(basis.min_mac),
            "worst_sample_mac_by_size": [float(x) for x in basis.min_mac_by_m], "basis_s": t_basis,
            "train_s": t_train}
    return Models(0, wing, mesh, 0, basis, roms), info


def models_at(models: Models, machs: Sequence[float]) -> Models:
    """The same models restricted to ``machs``."""
    return dataclasses.replace(models, roms={float(m): models.roms[float(m)] for m in machs})


def own_roms(models: Models, shapes: np.ndarray, ident: Mapping[str, Any], trainer: Trainer = Trainer()
             ) -> dict[float, tuple[int, Any]]:
    """ROMs trained on ``shapes`` [N, k] at every Mach of ``models`` (ROM-PMS) by ``trainer``, mach -> (0, rom)."""
    machs = sorted(models.roms)
    trained = trainer.roms(models.mesh, shapes, machs, ident)
    return {m: (0, rom) for m, rom in zip(machs, trained, strict=True)}


# ---- comparisons -------------------------------------------------------------------------------------------------
def _speeds(row: Mapping[str, Any]) -> tuple[float | None, float | None]:
    """(sqrt(2 q_f / rho_ref), EAS) in m/s of a use-case result row; (None, None) without flutter."""
    q, rho = row.get("q_flutter_pa"), row.get("rho_ref_kg_m3")
    if not row.get("flutter_found") or q is None or rho is None:
        return None, None
    return math.sqrt(2.0 * q / rho), row.get("v_eas_m_s")


def comparison_rows(ams: Mapping[str, Any], pms: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Per Mach: flutter speed (m/s) and frequency (rad/s) by ROM-AMS and ROM-PMS, relative errors in %."""
    by = {round(r["mach"], 6): r for r in pms["results"]}
    rows = []
    for a in ams["results"]:
        p = by[round(a["mach"], 6)]
        (va, ea), (vp, ep) = _speeds(a), _speeds(p)
        wa, wp = a.get("omega_flutter_rad_s"), p.get("omega_flutter_rad_s")
        rows.append({"mach": a["mach"], "v_rom_ams": va, "v_rom_pms": vp, "error_pct": pct_error(va, vp),
                     "omega_rom_ams": wa, "omega_rom_pms": wp, "omega_error_pct": pct_error(wa, wp),
                     "f_rom_ams_hz": a.get("frequency_hz"), "f_rom_pms_hz": p.get("frequency_hz"),
                     "v_eas_rom_ams": ea, "v_eas_rom_pms": ep, "mode_rom_ams": a.get("flutter_mode"),
                     "mode_rom_pms": p.get("flutter_mode"), "sdoff_rom_ams": a.get("sdoff"),
                     "sdoff_rom_pms": p.get("sdoff")})
    return rows


def flutter_rows(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Per Mach of a use-case summary: flutter speed (m/s, the paper's measure and EAS), q_f (Pa and psi), omega_f
    (rad/s), flutter mode, safe altitude (m) and the envelope margin to the benchmark (m, > 0 is safer)."""
    margins = summary.get("envelope_margin_m") or [None] * len(summary["results"])
    rows = []
    for r, margin in zip(summary["results"], margins, strict=True):
        v, eas = _speeds(r)
        q = r.get("q_flutter_pa")
        rows.append({"mach": r["mach"], "v": v, "v_eas": eas, "q_pa": q, "q_psi": None if q is None else q / PSI_PA,
                     "omega": r.get("omega_flutter_rad_s"), "mode": r.get("flutter_mode"), "sdoff": r.get("sdoff"),
                     "safe_altitude_m": r.get("safe_altitude_m"), "envelope_margin_m": margin})
    return rows


def structure_record(summary: Mapping[str, Any]) -> dict[str, Any]:
    """Mass (kg), frequencies (Hz), fit MACs, feasibility and per-Mach flutter rows of one evaluated structure."""
    return {"mass_kg": summary["mass_kg"], "frequencies_hz": summary["frequencies_hz"], "mac": summary["mac"],
            "constraints_ok": summary["constraints_ok"], "message": summary["message"],
            "flutter": flutter_rows(summary)}


def ams_and_pms(models: Models, design: Any, ident: Mapping[str, Any], cache: Memo, trainer: Trainer = Trainer(),
                condition: FlightCondition = DEFAULT_CONDITION) -> tuple[dict, dict, Any, Any]:
    """(ROM-AMS summary, ROM-PMS summary, ROM-AMS result, modal) of one design at the Machs of ``models``
    (``condition``: its projection_correction applies to ROM-AMS only)."""
    modal = structure_modal(models, design)
    ams, ams_result = evaluate_structure_summary(models, design=design, cache=cache, condition=condition)
    pms, _ = pms_summary(models, modal, own_roms(models, modal.shapes, ident, trainer), cache=cache)
    return ams, pms, ams_result, modal


def contrasting_pair(wing: WingDefinition, basis: Basis) -> tuple[int, int, float]:
    """The two basis samples whose modes differ most: lowest mean mode-by-mode MAC (i, j, that MAC)."""
    shapes = [snapshot(wing, x, basis.n_modes) for x in basis.designs]
    best = (0, 1, math.inf)
    for i, j in itertools.combinations(range(len(shapes)), 2):
        m = float(np.mean([mac(shapes[i][:, k], shapes[j][:, k]) for k in range(basis.n_modes)]))
        if m < best[2]:
            best = (i, j, m)
    return best


def table5(models: Models, ident: Mapping[str, Any], cache: Memo, trainer: Trainer = Trainer(),
           condition: FlightCondition = DEFAULT_CONDITION) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Table 5: ROM-AMS vs ROM-PMS at M 0.87 of the two most contrasting basis samples (var1, var2)."""
    at = models_at(models, [TABLE5_MACH])
    i, j, pair_mac = contrasting_pair(models.wing, models.basis)
    rows = []
    for name, k in (("var1", i), ("var2", j)):
        x = models.basis.designs[k].tolist()
        ams, pms, _, _ = ams_and_pms(at, x, ident, cache, trainer, condition)
        paper = PAPER_TABLE5[name]
        row = {"design": name, "lhs_sample": k, "x": dict(zip(models.wing.variable_names, x, strict=True)),
               **comparison_rows(ams, pms)[0], "mac": ams["mac"], "frequencies_hz": ams["frequencies_hz"],
               "paper": {"v_rom_ams": paper[0], "v_rom_pms": paper[1], "error_pct": pct_error(paper[0], paper[1]),
                         "omega_rom_ams": paper[2], "omega_rom_pms": paper[3]}}
        rows.append(row)
    return rows, {"samples": [i, j], "mean_mode_mac_between_them": pair_mac}


def fixed_mode_shapes(models: Models, modal_opt: Any, v_own: float | None, ident: Mapping[str, Any],
                      cache: Memo, trainer: Trainer = Trainer()) -> tuple[dict[str, Any], Any]:
    """Fig. 19/20: the optimum's frequencies and mass with the baseline plate's mass-normalized mode shapes (unit
    generalized masses, stiffnesses omega_opt^2: only the frequencies change) at M 0.87, ROMs trained on those
    shapes; flutter speed against the optimum's own modes (``v_own``, m/s). Returns (JSON, StructureEvaluation)."""
    at = models_at(models, [TABLE5_MACH])
    base = structure_modal(at, None)
    frozen = dataclasses.replace(base, omega=modal_opt.omega, frequencies_hz=modal_opt.frequencies_hz,
                                 mass_kg=modal_opt.mass_kg)
    summary, result = pms_summary(at, frozen, own_roms(at, base.shapes, ident, trainer), cache=cache)
    row = summary["results"][0]
    v_fixed, _ = _speeds(row)
    mac_shapes = [float(mac(base.shapes[:, k], modal_opt.shapes[:, k])) for k in range(base.shapes.shape[1])]
    return {"mach": TABLE5_MACH, "v_own_modes": v_own, "v_fixed_modes": v_fixed,
            "omega_fixed_modes": row["omega_flutter_rad_s"], "flutter_mode_fixed": row["flutter_mode"],
            "error_pct": pct_error(v_fixed, v_own),
            "mac_baseline_vs_optimum_modes": mac_shapes,
            "generalized_masses": "unit: the baseline's mass-normalized shapes, stiffness diag(omega_opt^2)",
            "paper": {**PAPER_FIXED_MODES, "error_pct": pct_error(PAPER_FIXED_MODES["v_fixed_modes"],
                                                             PAPER_FIXED_MODES["v_own_modes"])}}, result


# ---- optimization ------------------------------------------------------------------------------------------------
def optimize(service: InProcessService, generations: int, popsize: int, seed: int, mu: float = 10.0
             ) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """The paper's DE on FlutterProblem's penalty objective: (problem, run, baseline summary)."""
    from client.problem import FlutterProblem

    problem = FlutterProblem(service, 0, machs=sorted(service.models.roms), mu=mu,  # type: ignore[arg-type]
                             keep_history=False, penalty="binary", envelope_tol_m=0.01, run=False)  # no service
    baseline = problem.baseline()
    last = [-math.inf]

    def progress(msg: str) -> None:
        if time.perf_counter() - last[0] > 20 or msg.startswith(f"gen {generations:4d}"):
            last[0] = time.perf_counter()
            log(msg)

    run_ = EX.run_de(problem, generations, popsize, seed, log=progress)
    return problem, run_, baseline


def table7(optimum: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Table 7: fit MAC of each of the optimum's modes in the basis, with the paper's."""
    return [{"mode": k + 1, "mac": float(m), "frequency_hz": float(f), "paper_mac": PAPER_TABLE7[k]}
            for k, (m, f) in enumerate(zip(optimum["mac"], optimum["frequencies_hz"], strict=True))]


def with_paper_table8(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Table 8 rows with the paper's values of the same Mach."""
    for r in rows:
        v = EX.PAPER_TABLE8.get(round(r["mach"], 2))
        w = PAPER_TABLE8_OMEGA.get(round(r["mach"], 2))
        r["paper"] = None if v is None or w is None else {
            "v_rom_ams": v[0], "v_rom_pms": v[1], "error_pct": pct_error(v[0], v[1]),
            "omega_rom_ams": w[0], "omega_rom_pms": w[1], "omega_error_pct": pct_error(w[0], w[1])}
    return rows


def write_plots(out: Path, problem: Any, run_: dict[str, Any], baseline: dict[str, Any], models: Models,
                modal_opt: Any, fixed_result: Any) -> list[str]:
    """Fig. 15, 16, 18 (the example's figures), Fig. 19 (modes of the optimum and of the baseline) and Fig. 20
    (V-g of the optimum with fixed mode shapes) as PNG into ``out``."""
    from romams.plots.flutter import vg_figure
    from romams.plots.modes import plot_modes

    out.mkdir(parents=True, exist_ok=True)
    files = EX.write_figures(out, run_, problem.names, problem.lower, problem.upper, sorted(models.roms), baseline)
    for name, modal in (("modes_optimum.png", modal_opt), ("modes_baseline.png", structure_modal(models, None))):
        plot_modes(modal, models.mesh, name[:-4].replace("_", " ")).savefig(out / name, dpi=110)
        files.append(name)
    vg_figure(fixed_result.flutter[0], "optimum, baseline mode shapes, M 0.87").savefig(out / "vg_fixed_modes.png")
    files.append("vg_fixed_modes.png")
    return files


# ---- the case ----------------------------------------------------------------------------------------------------
def run(*, solver: str = "dlm", generations: int = EX.PAPER_GENERATIONS, popsize: int = EX.PAPER_NP, seed: int = 0,
        machs: Sequence[float] = EX.PAPER_MACHS, samples: int = 25, mac_threshold: float = 0.9999,
        max_basis: int = 12, train_options: Mapping[str, Any] | None = None, beam_placement: str = "eccentric",
        plot_dir: Path | None = None, processes: int = 1, rom_dir: Path | None = None,
        projection_correction: str = "auto") -> dict[str, Any]:
    """The whole case; returns the JSON-able result (keys: table5, table7, table8, fixed_mode_shapes_error_pct,
    mass_reduction_pct, optimum, settings, timings, paper ...)."""
    if TABLE5_MACH not in [float(m) for m in machs]:
        raise ValueError(f"machs: must include {TABLE5_MACH} (Table 5 and the fixed-mode analysis)")
    t_start = time.perf_counter()
    wing = cropped_delta(beam_placement=beam_placement)
    ident = rom_identity(solver, options=train_options, wing=wing)
    trainer = Trainer(processes, rom_dir)
    models, basis_info = build_models(wing, machs, ident, samples, mac_threshold, max_basis, trainer=trainer)
    cache = Memo()
    condition = FlightCondition.from_options(projection_correction=projection_correction)
    t0 = time.perf_counter()
    t5, pair = table5(models, ident, cache, trainer, condition)
    t_table5 = time.perf_counter() - t0
    log(f"Table 5 ({t_table5:.1f} s): " + ", ".join(f"{r['design']} {r['error_pct']}" for r in t5))
    service = InProcessService(models, cache, condition)
    t0 = time.perf_counter()
    problem, de, baseline = optimize(service, generations, popsize, seed)
    t_de = time.perf_counter() - t0
    x_opt = de["x"]
    t0 = time.perf_counter()
    ams, pms, _, modal_opt = ams_and_pms(models, x_opt, ident, cache, trainer, condition)
    t8 = with_paper_table8(comparison_rows(ams, pms))
    t_table8 = time.perf_counter() - t0
    own_087 = next(r["v_rom_pms"] for r in t8 if r["mach"] == TABLE5_MACH)
    t0 = time.perf_counter()
    fixed, fixed_result = fixed_mode_shapes(models, modal_opt, own_087, ident, cache, trainer)
    t_fixed = time.perf_counter() - t0
    mass0, mass = float(baseline["mass_kg"]), float(ams["mass_kg"])
    paper_x = [EX.PAPER_OPTIMUM[n] for n in problem.names]
    paper_opt = structure_record(service.evaluate(0, paper_x))  # the paper's Table 6 design in this model
    figures = write_plots(plot_dir, problem, de, baseline, models, modal_opt, fixed_result) if plot_dir else []
    paper_reduction = 100.0 * (EX.PAPER_BASELINE_MASS_KG - EX.PAPER_MASS_KG) / EX.PAPER_BASELINE_MASS_KG
    return {
        "solver": solver, "wing": "cropped-delta", "beam_placement": beam_placement, "machs": [float(m) for m in machs],
        "settings": {"F": EX.PAPER_F, "CR": EX.PAPER_CR, "Np": popsize, "generations": generations, "seed": seed,
                     "strategy": "rand1bin", "init": "latin hypercube", "mu_kg": 10.0, "penalty": "binary",
                     "envelope_tol_m": 0.01, "mac_constraint": 0.98, "rom_identity": ident,
                     "flight_condition": ams["flight_condition"]},
        "basis": basis_info,
        "table5": t5, "table5_pair": pair,
        "optimum": dict(zip(problem.names, x_opt, strict=True)), "paper_optimum": EX.PAPER_OPTIMUM,
        "optimum_mass_kg": mass, "baseline_mass_kg": mass0, "mass_reduction_pct": 100.0 * (mass0 - mass) / mass0,
        "optimum_feasible": bool(de["best"]["feasible"]), "optimum_frequencies_hz": ams["frequencies_hz"],
        "envelope": [{"mach": r["mach"], "safe_altitude_m": r["safe_altitude_m"], "benchmark_safe_altitude_m":
                      b["safe_altitude_m"]} for r, b in zip(ams["results"], baseline["results"], strict=True)],
        "baseline": structure_record(baseline), "paper_optimum_evaluated": paper_opt,
        "table7": table7(ams), "table8": t8,
        "fixed_mode_shapes": fixed, "fixed_mode_shapes_error_pct": fixed["error_pct"],
        "paper": {"mass_kg": EX.PAPER_MASS_KG, "baseline_mass_kg": EX.PAPER_BASELINE_MASS_KG,
                  "mass_reduction_pct": paper_reduction, "fixed_mode_shapes_error_pct": fixed["paper"]["error_pct"]},
        "evaluations": de["nfev"], "generations_run": de["generations"],
        "convergence": [{"generation": h["generation"], "best_objective": h["best_objective"],
                         "best_mass_kg": h["best_mass_kg"], "best_feasible": h["best_feasible"],
                         "n_feasible": h["n_feasible"]} for h in de["history"]],
        "timings_s": {"basis": basis_info["basis_s"], "training": sum(basis_info["train_s"].values()),
                      "table5": t_table5, "de": t_de, "de_per_structure": t_de / max(de["nfev"], 1),
                      "table8": t_table8, "fixed_modes": t_fixed, "total": time.perf_counter() - t_start},
        "figures": figures, "training_notes": list(trainer.notes),
    }


def main(argv: list[str] | None = None) -> None:
    """Command-line entry point: prints the JSON object (indented unless ``--json``)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"short DE ({QUICK_GENERATIONS} generations)")
    ap.add_argument("--solver", default="dlm", choices=SOLVERS, help="aerodynamic solver of the ROMs")
    ap.add_argument("--generations", type=int, default=None, help="DE generations (default: 150, --quick: 20)")
    ap.add_argument("--popsize", type=int, default=EX.PAPER_NP)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-basis", type=int, default=12, help="cap of the basis size (MAC >= 0.9999 decides)")
    ap.add_argument("--beam-placement", default="eccentric", choices=("eccentric", "mid-plane"))
    ap.add_argument("--processes", type=int, default=1, help="trainings in this many processes (the Machs)")
    ap.add_argument("--rom-dir", type=Path, default=None, metavar="DIR",
                    help="keep every trained ROM in DIR and reuse the stored ones (same mesh, shapes, Mach, identity)")
    ap.add_argument("--anchor-k", type=anchor_value, nargs="+", default=None,
                    help="tsd: the training option anchor_k at these k ('none': plain ROMs, as measured before "
                         "2026-12-04; default: the training's default anchors, docs/transonic.md 7.11)")
    ap.add_argument("--plot", type=Path, default=None, metavar="DIR", help="write the figures (PNG) into DIR")
    ap.add_argument("--projection-correction", default="auto", choices=PROJECTION_CORRECTIONS,
                    help="ROM-AMS's DLM projection residual (auto: on TSD ROMs; docs/transonic.md 7.12)")
    ap.add_argument("--json", action="store_true", help="one-line JSON")
    a = ap.parse_args(argv)
    gens = a.generations if a.generations is not None else (QUICK_GENERATIONS if a.quick else EX.PAPER_GENERATIONS)
    res = run(solver=a.solver, generations=gens, popsize=a.popsize, seed=a.seed, max_basis=a.max_basis,
              beam_placement=a.beam_placement, plot_dir=a.plot, processes=a.processes, rom_dir=a.rom_dir,
              train_options=anchor_options(a.anchor_k) or None, projection_correction=a.projection_correction)
    res["quick"] = bool(a.quick)
    print(json.dumps(res, indent=None if a.json else 1))


if __name__ == "__main__":
    main()
