"""``romams demo``: the ROM-AMS paper's whole pipeline on the embedded default (local SQLite store)."""

from __future__ import annotations

import json
import math
import os
import resource
import time
from pathlib import Path
from typing import Any

import numpy as np
import typer

from romams.cli import text
from romams.cli.app import app
from romams.pipeline import PAPER_MACHS, ensure_basis, ensure_roms, resolve_wing, rom_identity, train_shape_sets
from romams.services.evaluation import Models, evaluate, pms_summary, result_row
from romams.services.flight import DEFAULT_CONDITION
from romams.services.training import DEFAULT_SOLVER, SOLVERS, available, is_frequency_solver, quality_line
from romams_core.wing import template

#: Two contrasting designs of the cropped delta wing (like the paper's var1 and var2): var1 has a beam far
#: aft, a heavy outboard leading-edge mass and a thin plate (its flutter boundary drops below the
#: benchmark's: "dangerous"); var2 has the largest beam along the leading edge, no mass and the full plate
#: (a "safe" envelope, paid for with mass).
DEMO_DESIGNS = {
    "var1": {"x1": 0.65, "x2": 0.60, "x3": 0.82, "x4": 0.09, "x5": 1.8, "x6": 1.5, "x7": 0.6},
    "var2": {"x1": 0.15, "x2": 0.15, "x3": 0.60, "x4": 0.0, "x5": 2.0, "x6": 2.0, "x7": 1.0},
}

#: Measured natural frequencies of the bare cropped delta plate (Hz; reference data, first three modes).
MEASURED_HZ = (26.7, 88.2, 131.8)
#: Number of structures analysed in the paper's optimization (for the timing extrapolation).
PAPER_STRUCTURES = 4530
#: TSD settings of ``romams demo --quick --solver tsd`` (CI): half-resolution grid, 102 t* records, ARX orders 6,
#: the default anchors (a 60 t* hold left this grid's step unsettled: anchored validation NRMSE 18 %)
TSD_QUICK_OPTIONS = {"grid_scale": 0.5, "n_steps": 1024, "nrmse_tol": 0.12}
#: DLM settings of ``romams demo --quick``: one box per standard-mesh panel (7x faster training than the default
#: 2x2, at about 9 % GAF error against a 4x lattice instead of 3 %; ROM-AMS and ROM-PMS share it)
DLM_QUICK_OPTIONS = {"lattice_refine": 1}


class _Console:
    """Readable progress on stderr (stdout stays free): step rules, log lines with the elapsed wall time, tables
    and progress bars (``romams.cli.text``)."""

    def __init__(self) -> None:
        self.c = text.console(stderr=True)
        self.t0 = time.perf_counter()

    def step(self, headline: str) -> None:
        """A numbered step headline."""
        self.c.rule(f"[bold]{headline}")

    def __call__(self, line: str) -> None:
        """One log line with the elapsed wall time."""
        self.c.print(f"[dim]{time.perf_counter() - self.t0:6.1f} s[/dim]  {line}")

    def table(self, title: str | None, columns: list[str], rows: list[list[Any]]) -> None:
        """A fixed-width table (4 significant figures, units in the headers)."""
        self.c.print(text.table(title, columns, rows))

    def bar(self, description: str) -> Any:
        """A progress bar for a wait (context manager yielding the progress callback)."""
        return text.progress_bar(self.c, description)


def _clocks() -> tuple[float, float]:
    """(wall, CPU) seconds now; CPU counts this process and its finished children (training processes)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter(), me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _since(start: tuple[float, float]) -> tuple[float, float]:
    """(wall, CPU) seconds since ``start`` (``_clocks()``)."""
    wall, cpu = _clocks()
    return wall - start[0], cpu - start[1]


def _median_ms(fn: Any, repeats: int) -> tuple[float, float]:
    """Median (wall, CPU) time of ``fn()`` in milliseconds, in this process."""
    walls, cpus = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return 1e3 * float(np.median(walls)), 1e3 * float(np.median(cpus))


def _design_row(models: Models, ams: Any, ref: dict[str, Any]) -> dict[str, Any]:
    """One Mach of a demo design: the ROM-AMS result row with the ROM-PMS reference and their differences; the
    accuracy is in flutter speed EAS (sqrt(q_f)): on a constant-speed sweep the true speed is M a_ref."""
    row = result_row(ams, None, *models.roms[float(ams.mach)])
    row["v_eas_pms_m_s"] = ref["v_eas_m_s"]
    row["v_flutter_pms_m_s"] = ref["v_flutter_m_s"]
    row["omega_flutter_pms_rad_s"] = ref["omega_flutter_rad_s"]
    ok = row["v_eas_m_s"] is not None and row["v_eas_pms_m_s"] is not None
    row["error_pct"] = 100.0 * (row["v_eas_m_s"] / row["v_eas_pms_m_s"] - 1.0) if ok else None
    row["omega_error_pct"] = (100.0 * (row["omega_flutter_rad_s"] / row["omega_flutter_pms_rad_s"] - 1.0)
                              if ok else None)
    return row


def _envelope_json(env: Any) -> list[dict[str, Any]]:
    """Per-Mach envelope rows."""
    return [{"mach": float(m), "q_flutter_pa": None if not math.isfinite(q) else float(q),
             "q_safe_pa": None if not math.isfinite(qs) else float(qs), "safe_altitude_m": float(h), "status": s}
            for m, q, qs, h, s in zip(env.mach, env.q_flutter_pa, env.q_safe_pa, env.safe_altitude_m, env.status,
                                      strict=True)]


def _plots(out: Path, baseline_eval: Any, designs: dict[str, Any], basis: Any, mesh: Any,
           roms: dict[float, Any]) -> list[str]:
    """Envelope, V-g / V-omega, basis and (TSD) mean-flow Cp figures; returns paths."""
    from romams.plots import basis as bplots
    from romams.plots import flutter as fplots
    from romams.plots.transonic import plot_mean_flow_cp

    paths: list[str] = []
    for m, (_, rom) in roms.items():
        if getattr(rom, "mean_flow", None):
            p = out / f"mean_flow_cp_M{m:.2f}.png"
            bplots.save(plot_mean_flow_cp(rom.mean_flow), str(p))
            paths.append(str(p))
    fig = bplots.plot_basis_shapes(mesh, basis.shapes, basis.singular_values)
    bplots.save(fig, str(out / "basis_shapes.png"))
    paths.append(str(out / "basis_shapes.png"))
    envs = {k: v.envelope for k, v in designs.items()}
    for ext in ("png", "svg"):
        (out / f"envelope.{ext}").write_bytes(fplots.envelope_plot(envs, baseline_eval.envelope, fmt=ext))
        paths.append(str(out / f"envelope.{ext}"))
    for name, ev in designs.items():
        for r in ev.flutter:
            p = out / f"vg_{name}_M{r.mach:.2f}.png"
            p.write_bytes(fplots.vg_plot(r, title=f"{name}, M = {r.mach:.2f} ({r.sweep}, {r.coupling})"))
            paths.append(str(p))
    return paths


@app.command("demo")
def demo_command(
    quick: bool = typer.Option(False, "--quick", help="coarser settings (for CI): fewer samples, shorter signals"),
    out: Path = typer.Option(Path("demo-out"), "--out", help="output directory for summary.json and plots"),
    processes: int = typer.Option(0, "--processes", min=0, help="parallel training processes (0: CPU count)"),
    solver: str = typer.Option(DEFAULT_SOLVER, "--solver", help="aerodynamic solver of the ROMs: dlm (default), "
                               "uvlm or tsd (transonic; with --quick: M 0.87 only, on a half-resolution grid)"),
) -> None:
    """Run the ROM-AMS pipeline on the cropped delta wing and write DIR/summary.json plus plots."""
    from romams.persistence import open_store
    from romams_core.basis import project
    from romams_core.mesh import standard_mesh
    from romams_core.structure.modal import modal_analysis

    log = _Console()
    out.mkdir(parents=True, exist_ok=True)
    procs = processes or os.cpu_count() or 1
    samples = 12 if quick else 25
    if solver not in SOLVERS or not available(solver):
        raise typer.BadParameter(f"unknown or unavailable solver {solver!r}", param_hint="--solver")
    condition = DEFAULT_CONDITION  # the service's default: constant speed V = M a(10 km), q swept (the paper's)
    machs = list(PAPER_MACHS)
    if solver == "tsd" and quick:  # minutes per TSD training: one transonic Mach, a coarse grid, short records
        ident = rom_identity(solver, 6, 6, TSD_QUICK_OPTIONS, wing=template("cropped-delta"))
        machs = [0.87]
    else:
        quick_opts = DLM_QUICK_OPTIONS if quick and solver == "dlm" else None
        ident = rom_identity(solver, options=quick_opts, wing=template("cropped-delta"))
    timings: dict[str, Any] = {}
    store = open_store()

    log.step("1. Cropped delta wing: bare baseline plate")
    wing_id, wing = resolve_wing(store, "cropped-delta")
    mesh = standard_mesh(wing.planform)
    base = modal_analysis(wing, None, 4, mesh)
    log(f"baseline plate: mass {text.sig(base.mass_kg)} kg")
    log.table(None, ["mode", "f (Hz)", "measured (Hz)"],
              [[i + 1, float(f), MEASURED_HZ[i] if i < len(MEASURED_HZ) else None]
               for i, f in enumerate(base.frequencies_hz)])

    log.step(f"2. PCA basis: {samples} LHS samples x 4 modes")
    start = _clocks()
    with log.bar("modal analyses of the samples") as bar:
        basis_id, basis = ensure_basis(store, wing_id, wing, samples=samples, modes=4, mac_threshold=0.9999,
                                       max_basis=8, seed=0, log=log, progress=bar)
    timings["pca_basis_s"] = _since(start)[0]
    mac_table = np.asarray(basis.mac_table).reshape(-1, 4) if np.size(basis.mac_table) % 4 == 0 else None

    kind = "rational-function (RFA)" if is_frequency_solver(solver) else "ARX"
    log.step(f"3. {solver.upper()} {kind} ROM per Mach ({len(machs)} trainings, {min(procs, len(machs))} in parallel)")
    start = _clocks()
    with log.bar(f"training {len(machs)} {solver} ROM(s)") as bar:
        roms = ensure_roms(store, wing_id, wing, basis_id, basis, machs, ident=ident, processes=procs,
                           log=lambda line: None, progress=bar)
    timings["training_wall_s"], timings["training_cpu_s"] = _since(start)
    timings["training_per_mach_s"] = float(np.mean([r.train_seconds for _, r in roms.values()]))
    models = Models(wing_id, wing, mesh, basis_id, basis, roms)
    log.table(None, ["Mach", "ROM", "quality", "states", "training (s, wall)"],
              [[f"{m:.2f}", rid, quality_line(r).split(" (")[0], int(r.ss.A.shape[0]), float(r.train_seconds)]
               for m, (rid, r) in roms.items()])
    for m, (_, r) in roms.items():
        if getattr(r, "mean_flow", None):
            mf = r.mean_flow
            log(f"M = {m:.2f}: TSD mean flow {'converged' if mf['steady_converged'] else 'NOT converged'} in "
                f"{mf['steady_steps']} steps, min Cp {text.sig(float(np.nanmin(mf['cp_upper'])))} "
                f"(sonic {text.sig(mf['cp_star'])})")

    baseline_eval = evaluate(models, base, condition)
    env = baseline_eval.envelope
    log.table("benchmark envelope (baseline plate)", ["Mach", "flutter q (Pa)", "safe altitude (m)"],
              [[f"{m:.2f}", float(q), float(h)] for m, q, h in zip(env.mach, env.q_flutter_pa, env.safe_altitude_m,
                                                                   strict=True)])

    log.step("4. Two contrasting designs: ROM-AMS vs ROM-PMS")
    design_rows = []
    design_evals = {}
    modals = {name: modal_analysis(wing, design, 4, mesh) for name, design in DEMO_DESIGNS.items()}
    start = _clocks()
    with log.bar(f"ROM-PMS: {len(modals)} x {len(machs)} trainings on the designs' own modes") as bar:
        pms_sets = dict(zip(modals, train_shape_sets(mesh, [m.shapes for m in modals.values()], machs, ident,
                                                     procs, progress=bar), strict=True))
    timings["rom_pms_training_s"], timings["rom_pms_training_cpu_s"] = _since(start)  # both designs, all Machs
    for name, design in DEMO_DESIGNS.items():
        modal = modals[name]
        ev = evaluate(models, modal, condition, benchmark=baseline_eval.envelope)
        design_evals[name] = ev
        own = {m: (models.roms[m][0], r) for m, r in zip(machs, pms_sets[name], strict=True)}  # the settings' ids
        pms, _ = pms_summary(models, modal, own, condition)
        rows = [_design_row(models, ams, ref) for ams, ref in zip(ev.flutter, pms["results"], strict=True)]
        design_rows.append({
            "name": name, "design": design, "mass_kg": float(modal.mass_kg),
            "frequencies_hz": [float(f) for f in modal.frequencies_hz], "mac": [float(x) for x in ev.mac],
            "results": rows, "envelope": _envelope_json(ev.envelope),
            "envelope_ok": None if ev.comparison is None else bool(ev.comparison.envelope_ok),
            "constraints_ok": bool(ev.constraints_ok), "message": ev.message,
        })
        log.table(f"{name}: mass {text.sig(modal.mass_kg)} kg, MAC " + ", ".join(text.sig(x, 6) for x in ev.mac),
                  ["Mach", "V_EAS ROM-AMS (m/s)", "V_EAS ROM-PMS (m/s)", "error (%)", "f_flutter (Hz)",
                   "safe altitude (m)"],
                  [[f"{r['mach']:.2f}", r["v_eas_m_s"], r["v_eas_pms_m_s"], text.sig(r["error_pct"], signed=True),
                    None if r["omega_flutter_rad_s"] is None else r["omega_flutter_rad_s"] / (2 * math.pi),
                    h] for r, h in zip(rows, ev.envelope.safe_altitude_m, strict=True)])
        log(f"{name}: {ev.message}")

    log.step("5. Timing per structure (one process)")
    design = DEMO_DESIGNS["var1"]
    with log.bar("timing the per-structure steps") as bar:
        modal_ms, modal_cpu_ms = _median_ms(lambda: modal_analysis(wing, design, 4, mesh), 7)
        bar(0.3, "flutter")
        modal = modal_analysis(wing, design, 4, mesh)
        flutter_ms, flutter_cpu_ms = _median_ms(
            lambda: evaluate(models, modal, condition, benchmark=baseline_eval.envelope), 5)
        bar(0.9, "projection")
        proj_ms, _ = _median_ms(lambda: project(basis.shapes, modal.shapes), 20)
    per_structure_s = (modal_ms + flutter_ms) / 1e3
    # measured ROM-PMS training per design (a frequency-domain solver reuses its factorized AICs after the first)
    pms_per_structure_s = timings["rom_pms_training_s"] / len(DEMO_DESIGNS) + per_structure_s
    timings.update({
        "modal_analysis_ms": modal_ms, "modal_analysis_cpu_ms": modal_cpu_ms, "projection_ms": proj_ms,
        "flutter_5_machs_ms": flutter_ms, "flutter_5_machs_cpu_ms": flutter_cpu_ms,
        "structure_eval_ms": modal_ms + flutter_ms,
        "rom_ams_4530_structures_min": (timings["pca_basis_s"] + timings["training_wall_s"]
                                        + PAPER_STRUCTURES * per_structure_s) / 60.0,
        "rom_pms_per_structure_s": pms_per_structure_s,
        "rom_pms_4530_structures_h": PAPER_STRUCTURES * pms_per_structure_s / 3600.0,
        "rom_pms_over_rom_ams_per_structure": pms_per_structure_s / per_structure_s,
        "processes": procs,
    })
    t = timings
    log.table(None, ["step", "wall", "CPU", "unit", "note"], [
        ["PCA basis", t["pca_basis_s"], None, "s", f"{samples} samples"],
        ["ROM training, all Machs", t["training_wall_s"], t["training_cpu_s"], "s", f"{procs} processes"],
        ["ROM training, one Mach", t["training_per_mach_s"], None, "s", "in its process"],
        ["modal analysis", modal_ms, modal_cpu_ms, "ms", "median of 7"],
        ["projection on the basis", proj_ms, None, "ms", "median of 20"],
        [f"flutter, {len(machs)} Mach(s)", flutter_ms, flutter_cpu_ms, "ms", "median of 5"],
        ["ROM-AMS, 4530 structures", t["rom_ams_4530_structures_min"], None, "min", "basis + training + evals"],
        ["ROM-PMS, per structure", pms_per_structure_s, None, "s", "own-mode training + eval"],
        ["ROM-PMS, 4530 structures", t["rom_pms_4530_structures_h"], None, "h", "extrapolated"],
        ["ROM-PMS / ROM-AMS", t["rom_pms_over_rom_ams_per_structure"], None, "-", "per structure"],
    ])

    summary = {
        "wing": wing.name,
        "quick": quick,
        "sweep": condition.sweep,
        "flight_condition": condition.to_json(),
        "machs": machs,
        "baseline": {"frequencies_hz": [float(f) for f in base.frequencies_hz], "mass_kg": float(base.mass_kg),
                     "envelope": _envelope_json(baseline_eval.envelope),
                     "results": [result_row(r, None, *models.roms[float(r.mach)]) for r in baseline_eval.flutter]},
        "basis": {"n_basis": int(basis.n_basis), "min_mac": float(basis.min_mac), "samples": samples, "modes": 4,
                  "mac_threshold": float(basis.mac_threshold),
                  "mac_table": None if mac_table is None else np.round(mac_table, 6).tolist()},
        "roms": [{"mach": m, "rom_id": rid, "solver": r.solver,
                  "validation_nrmse": [float(x) for x in r.validation_nrmse], "states": int(r.ss.A.shape[0]),
                  "train_seconds": float(r.train_seconds),
                  **({"mean_flow_converged": r.mean_flow["steady_converged"],
                      "mean_flow_steps": r.mean_flow["steady_steps"]} if getattr(r, "mean_flow", None) else {}),
                  **({"anchor_k": [float(k) for k in r.anchor_k], "anchor_band_error": r.anchor_band_error}
                     if getattr(r, "anchor_k", None) is not None else {})}
                 for m, (rid, r) in roms.items()],
        "designs": design_rows,
        "timings": timings,
    }
    with log.bar("writing the plots") as bar:
        summary["plots"] = _plots(out, baseline_eval, design_evals, basis, mesh, roms)
        bar(1.0, "done")
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    log(f"wrote {out / 'summary.json'} and {len(summary['plots'])} plots in {time.perf_counter() - log.t0:.1f} s "
        "(wall)")


__all__ = ["demo_command", "DEMO_DESIGNS"]
