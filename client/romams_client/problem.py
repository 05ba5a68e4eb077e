"""FlutterProblem: objective and constraints of a flutter-constrained mass minimization over HTTP.

One batch request per call, vectorized over a population. The penalty objective is the ROM-AMS
paper's: mass + mu * C(x) with C = 1 when any constraint fails, the constraints being (1) the safe
flight envelope not above the baseline structure's at any Mach (the service compares them), (2) no
single-degree-of-freedom flutter at any Mach, (3) every mode fitted by the basis with MAC >= 0.98.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from romams_client.errors import RomamsError
from romams_client.http import RomamsClient, WingRef


@dataclass
class BatchEvaluation:
    """Objective and constraint data of a population [n, d] at n_mach Mach numbers (SI units)."""

    x: np.ndarray  # [n, d] design vectors
    objective: np.ndarray  # [n] mass + mu * C (kg)
    mass_kg: np.ndarray  # [n], NaN when the service could not evaluate the design
    feasible: np.ndarray  # [n] bool, C == 0
    envelope_ok: np.ndarray  # [n] bool (True when the wing has no baseline to compare with)
    envelope_margin_m: np.ndarray  # [n, n_mach] baseline safe altitude - design safe altitude (m), > 0 is safer
    safe_altitude_m: np.ndarray  # [n, n_mach]
    v_flutter_m_s: np.ndarray  # [n, n_mach] true airspeed at flutter (m/s), NaN without flutter in range
    v_eas_m_s: np.ndarray  # [n, n_mach] equivalent airspeed at flutter (m/s): carries q_f on any sweep
    omega_flutter_rad_s: np.ndarray  # [n, n_mach]
    sdoff: np.ndarray  # [n] bool, SDOFF at any Mach
    min_mac: np.ndarray  # [n] worst mode-fit MAC
    machs: np.ndarray  # [n_mach]
    errors: list[str | None] = field(default_factory=list)  # per design: why it could not be evaluated
    # [n, n_mach] the service's envelope status: "ok", or the safe altitude sits at a cap of the searched altitude
    # range: "safe-everywhere" (range bottom; also without flutter in the speed sweep), "unsafe-in-range" (range
    # top); "" where the service gave none
    envelope_status: np.ndarray = field(default_factory=lambda: np.empty((0, 0), dtype=object))
    flutter_found: np.ndarray = field(default_factory=lambda: np.empty((0, 0), dtype=bool))  # [n, n_mach]

    def at_cap(self) -> np.ndarray:
        """[n, n_mach] True where the safe altitude sits at a cap of the searched range (not a flutter result)."""
        return (self.envelope_status != "ok") & (self.envelope_status != "")

    def constraints(self) -> dict[str, np.ndarray]:
        """Constraint arrays by name: mass, envelope margin per Mach, sdoff, min_mac, feasible."""
        return {"mass": self.mass_kg, "envelope_margin_m": self.envelope_margin_m, "envelope_ok": self.envelope_ok,
                "sdoff": self.sdoff, "min_mac": self.min_mac, "feasible": self.feasible,
                "safe_altitude_m": self.safe_altitude_m, "v_flutter_m_s": self.v_flutter_m_s,
                "v_eas_m_s": self.v_eas_m_s}


def _num(v: Any) -> float:
    """Float of a JSON number, NaN for null."""
    return math.nan if v is None else float(v)


class FlutterProblem:
    """Penalty objective mass + mu * C(x) of ``wing`` on the service behind ``client``.

    ``machs``: Mach numbers to evaluate (default: all trained for the latest basis). ``mu``: penalty (kg).
    ``mac_threshold``: smallest acceptable mode-fit MAC. ``envelope_tol_m``: a safe altitude up to this
    much above the baseline's still counts as "not above" (the flutter search is converged to ~1e-12
    relative, so the baseline compared with itself differs by ~1e-8 m). ``penalty``: "binary" (the
    paper: C = 1 for any violation) or "graded" (C = 1 + the violations: envelope excess in km, MAC
    deficit / 0.02, number of SDOFF flags; guides a population that has no feasible member yet).
    Call it with X [pop, d] (objective [pop]) or X [d] (a float); :meth:`for_scipy` takes scipy's
    vectorized layout [d, pop]. Every evaluated batch is appended to ``history``. ``run``: the service stores every
    evaluated design under a run (True: a new run named after the wing; a string: a new run of that name; False:
    none); ``run_id`` is its id (the dashboard's run page: /dashboard/runs/{run_id}). ``keep_vg``: keep every
    design's V-g data (by default only the run's new best designs keep them).
    """

    def __init__(self, client: RomamsClient, wing: WingRef, machs: Sequence[float] | None = None, mu: float = 10.0,
                 mac_threshold: float = 0.98, basis_id: int | None = None, keep_history: bool = True,
                 envelope_tol_m: float = 0.01, penalty: str = "binary", run: str | bool | None = True,
                 keep_vg: bool = False) -> None:
        if not (math.isfinite(mu) and mu > 0):
            raise ValueError(f"mu: must be a finite penalty > 0 (kg), got {mu!r}")
        if not 0.0 < mac_threshold <= 1.0:
            raise ValueError(f"mac_threshold: must be in (0, 1], got {mac_threshold!r}")
        if not (math.isfinite(envelope_tol_m) and envelope_tol_m >= 0):
            raise ValueError(f"envelope_tol_m: must be a finite altitude >= 0 (m), got {envelope_tol_m!r}")
        if penalty not in ("binary", "graded"):
            raise ValueError(f"penalty: must be 'binary' or 'graded', got {penalty!r}")
        self.envelope_tol_m = float(envelope_tol_m)
        self.penalty = penalty
        self.client = client
        info = client.get_wing(wing)
        self.wing_id = int(info["id"])
        dvs = info.get("design_variables") or []
        if not dvs:
            raise ValueError(f"wing: {wing!r} has no design variables")
        self.names = [str(v["name"]) for v in dvs]
        self.lower = np.array([float(v["lower"]) for v in dvs])
        self.upper = np.array([float(v["upper"]) for v in dvs])
        trained = [float(m) for m in info.get("trained_machs") or []]
        self.machs = np.array(sorted(float(m) for m in machs) if machs is not None else trained, dtype=float)
        if self.machs.size == 0:
            raise ValueError(f"machs: wing {wing!r} has no trained ROM; train at least one Mach first")
        self.mu = float(mu)
        self.mac_threshold = float(mac_threshold)
        self.basis_id = basis_id
        self.keep_history = keep_history
        self.history: list[BatchEvaluation] = []
        self.n_calls = 0  # batch requests sent
        self.n_evaluations = 0  # designs evaluated
        self._last: BatchEvaluation | None = None
        self.keep_vg = bool(keep_vg)
        self.run_id = self._create_run(run, info)

    def _create_run(self, run: str | bool | None, info: dict[str, Any]) -> int | None:
        """Id of the run this problem's batches are stored under (a new one unless ``run`` is False/None); None
        when the service has no runs (an older version answering 404)."""
        if run is None or run is False:
            return None
        name = run if isinstance(run, str) else f"{info.get('name', self.wing_id)}: mass, flutter envelope"
        try:
            created = self.client.create_run(name, self.wing_id, mu_kg=self.mu, mac_threshold=self.mac_threshold,
                                             envelope_tol_m=self.envelope_tol_m, penalty=self.penalty)
        except RomamsError as exc:
            if exc.status in (404, 405):
                return None
            raise
        return int(created["id"])

    @property
    def dim(self) -> int:
        """Number of design variables d."""
        return len(self.names)

    @property
    def bounds(self) -> list[tuple[float, float]]:
        """(lower, upper) of each design variable, in the wing's order."""
        return list(zip(self.lower.tolist(), self.upper.tolist(), strict=True))

    def _as_population(self, x: Any) -> tuple[np.ndarray, bool]:
        """X as [n, d] and whether a single design was given."""
        arr = np.asarray(x, dtype=float)
        single = arr.ndim == 1
        arr = np.atleast_2d(arr)
        if arr.ndim != 2 or arr.shape[1] != self.dim:
            raise ValueError(f"x: expected [pop, {self.dim}] or [{self.dim}] design vectors "
                             f"({', '.join(self.names)}), got shape {np.shape(x)}")
        return arr, single

    def baseline(self) -> dict[str, Any]:
        """The service's evaluation of the wing's baseline structure (the envelope benchmark) at ``machs``."""
        return self.client.evaluate(self.wing_id, None, machs=self.machs.tolist(), basis_id=self.basis_id,
                                    store=True)

    def evaluate(self, x: Any) -> BatchEvaluation:
        """Evaluate a population [n, d] (or one design [d]) with one batch request."""
        pop, _ = self._as_population(x)
        if self._last is not None and self._last.x.shape == pop.shape and np.array_equal(self._last.x, pop):
            return self._last
        results = self.client.evaluate_batch(self.wing_id, pop, machs=self.machs.tolist(), basis_id=self.basis_id,
                                             run_id=self.run_id, keep_vg=self.keep_vg)
        self.n_calls += 1
        self.n_evaluations += pop.shape[0]
        ev = self._collect(pop, results)
        self._last = ev
        if self.keep_history:
            self.history.append(ev)
        return ev

    def _collect(self, pop: np.ndarray, results: list[dict[str, Any]]) -> BatchEvaluation:
        """BatchEvaluation from the service's per-design result dicts."""
        n, k = pop.shape[0], self.machs.size
        mass = np.full(n, math.nan)
        env_ok = np.zeros(n, dtype=bool)
        margin = np.full((n, k), math.nan)
        alt = np.full((n, k), math.nan)
        vf = np.full((n, k), math.nan)
        ve = np.full((n, k), math.nan)
        wf = np.full((n, k), math.nan)
        status = np.full((n, k), "", dtype=object)
        found = np.zeros((n, k), dtype=bool)
        sdoff = np.zeros(n, dtype=bool)
        min_mac = np.full(n, math.nan)
        errors: list[str | None] = []
        for i, r in enumerate(results):
            if "error" in r or r.get("mass_kg") is None:
                errors.append(str(r.get("error") or "no mass in the result"))
                continue
            errors.append(None)
            mass[i] = float(r["mass_kg"])
            per = {round(float(p["mach"]), 6): p for p in r.get("results") or []}
            for j, m in enumerate(self.machs):
                p = per.get(round(float(m), 6))
                if p is not None:
                    alt[i, j] = _num(p.get("safe_altitude_m"))
                    vf[i, j] = _num(p.get("v_flutter_m_s"))
                    ve[i, j] = _num(p.get("v_eas_m_s"))
                    wf[i, j] = _num(p.get("omega_flutter_rad_s"))
                    status[i, j] = str(p.get("envelope_status") or "")
                    found[i, j] = bool(p.get("flutter_found", np.isfinite(vf[i, j])))
            if r.get("envelope_margin_m") is not None:
                margin[i] = np.asarray(r["envelope_margin_m"], dtype=float)
            if r.get("envelope_ok") is None:  # the wing has no baseline: nothing to compare with
                env_ok[i] = True
            else:
                env_ok[i] = bool(r["envelope_ok"]) or bool(np.all(margin[i] >= -self.envelope_tol_m))
            sdoff[i] = bool(r.get("sdoff")) or any(bool(p.get("sdoff")) for p in per.values())
            mac = r.get("mac")
            min_mac[i] = float(np.min(mac)) if mac else _num(r.get("min_mac"))
        ok_mac = np.nan_to_num(min_mac, nan=-1.0) >= self.mac_threshold
        feasible = env_ok & ~sdoff & ok_mac & np.isfinite(mass)
        c = (~feasible).astype(float)
        if self.penalty == "graded":
            excess_km = np.nansum(np.clip(-np.nan_to_num(margin, nan=0.0), 0.0, None), axis=1) / 1e3
            mac_deficit = np.clip(self.mac_threshold - np.nan_to_num(min_mac, nan=0.0), 0.0, None) / 0.02
            n_sdoff = np.array([sum(bool(p.get("sdoff")) for p in (r.get("results") or [])) for r in results])
            c = np.where(feasible, 0.0, 1.0 + excess_km * (~env_ok) + mac_deficit + n_sdoff)
        objective = np.where(np.isfinite(mass), np.nan_to_num(mass) + self.mu * c, 2.0 * self.mu * (1 + c))
        return BatchEvaluation(pop.copy(), objective, mass, feasible, env_ok, margin, alt, vf, ve, wf, sdoff, min_mac,
                               self.machs.copy(), errors, status, found)

    def __call__(self, x: Any) -> np.ndarray | float:
        """Penalty objective (kg): [pop] for X [pop, d], a float for one design [d]."""
        _, single = self._as_population(x)
        obj = self.evaluate(x).objective
        return float(obj[0]) if single else obj

    def inequality_constraints(self, ev: BatchEvaluation) -> np.ndarray:
        """Constraints of a batch as G [n, n_mach + 2] <= 0 (pymoo's and Optuna's convention), feasible iff all hold.

        Columns: per Mach the envelope excess ``-margin - envelope_tol_m`` (m); the MAC deficit
        ``mac_threshold - min_mac``; the SDOFF flag (1 when present). A design the service could not evaluate gets
        a MAC deficit above 1, one without a baseline to compare with an envelope column of 0.
        """
        margin = ev.envelope_margin_m
        env = np.where(np.isnan(margin), np.where(ev.envelope_ok, 0.0, 1e3)[:, None], -margin - self.envelope_tol_m)
        mac = self.mac_threshold - np.nan_to_num(ev.min_mac, nan=-1.0)
        return np.column_stack([env, mac, ev.sdoff.astype(float)])

    def constraints(self, x: Any) -> dict[str, np.ndarray]:
        """mass [n], envelope_margin_m [n, n_mach], envelope_ok, sdoff, min_mac and feasible [n] of X."""
        return self.evaluate(x).constraints()

    def for_scipy(self, x: np.ndarray) -> np.ndarray | float:
        """Objective in scipy.optimize.differential_evolution's vectorized layout: x [d, S] -> [S] (or [d] -> float)."""
        arr = np.asarray(x, dtype=float)
        return self(arr.T) if arr.ndim == 2 else self(arr)

    def normalize(self, x: Any) -> np.ndarray:
        """Design vectors scaled to [0, 1] by the bounds."""
        return (np.asarray(x, dtype=float) - self.lower) / (self.upper - self.lower)

    def denormalize(self, u: Any) -> np.ndarray:
        """Unit-cube points mapped to the design bounds."""
        return self.lower + np.asarray(u, dtype=float) * (self.upper - self.lower)
