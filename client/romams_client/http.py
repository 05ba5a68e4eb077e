"""RomamsClient: a small typed HTTP client of the ROM-AMS flutter service (``/api/v1``).

Only httpx, tqdm, numpy and the standard library are imported here: the client is what gets installed
on optimizer machines. Errors of the service (RFC 9457 problem+json) surface as :class:`RomamsError`
with the server's status, title, detail and offending ``field``; connection errors and 502/503/504 are
retried with exponential backoff (honouring ``Retry-After``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote

import httpx
import numpy as np

from romams_client.errors import JobError, JobTimeout, RomamsError

#: statuses that mean "try again later" (the service or a proxy in front of it is momentarily unavailable)
RETRY_STATUSES = frozenset({502, 503, 504})
#: transport errors after which a request is retried
RETRY_EXCEPTIONS: tuple[type[Exception], ...] = (
    httpx.ConnectError, httpx.ConnectTimeout, httpx.PoolTimeout, httpx.ReadError, httpx.WriteError,
    httpx.RemoteProtocolError,
)
FINAL_STATUSES = frozenset({"succeeded", "failed", "cancelled"})

DesignLike = Mapping[str, float] | Sequence[float] | np.ndarray
WingRef = int | str


def _design_json(design: DesignLike | None) -> Any:
    """JSON form of one design: a {name: value} dict or a list of floats (None = the baseline)."""
    if design is None:
        return None
    if isinstance(design, Mapping):
        return {str(k): float(v) for k, v in design.items()}
    arr = np.asarray(design, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"design: must be one vector of design variables, got shape {arr.shape}")
    return arr.tolist()


def _model_choice(machs: Sequence[float] | None, basis_id: int | None, solver: str | None) -> dict[str, Any]:
    """The optional request fields that pick the models of an evaluation: Machs, basis, solver (only those given)."""
    body: dict[str, Any] = {}
    if machs is not None:
        body["machs"] = [float(m) for m in machs]
    if basis_id is not None:
        body["basis_id"] = int(basis_id)
    if solver is not None:
        body["solver"] = str(solver)
    return body


def _designs_json(designs: Iterable[DesignLike] | np.ndarray) -> list[Any]:
    """JSON form of several designs ([n, d] array, list of vectors or of dicts)."""
    if isinstance(designs, np.ndarray):
        arr = np.atleast_2d(np.asarray(designs, dtype=float))
        if arr.ndim != 2:
            raise ValueError(f"designs: must be [n, d], got shape {designs.shape}")
        return arr.tolist()
    return [_design_json(d) for d in designs]


class RomamsClient:
    """Client of one service at ``base_url`` (e.g. ``http://127.0.0.1:8000``).

    ``api_key`` is sent as ``Authorization: Bearer``; ``timeout`` (s) bounds one HTTP request; ``retries``
    is how many times a request is repeated after a connection error or a 502/503/504, waiting
    ``backoff * 2**attempt`` s (at most ``max_backoff``) in between. ``transport`` replaces httpx's
    network transport (tests); ``sleep`` replaces time.sleep for the backoff waits.
    """

    def __init__(self, base_url: str = "http://127.0.0.1:8000", api_key: str | None = None, timeout: float = 120.0,
                 retries: int = 5, backoff: float = 0.5, max_backoff: float = 10.0, *,
                 transport: httpx.BaseTransport | None = None, sleep: Callable[[float], None] = time.sleep) -> None:
        if retries < 0:
            raise ValueError(f"retries: must be >= 0, got {retries}")
        if not (backoff >= 0 and max_backoff >= 0):
            raise ValueError("backoff: backoff and max_backoff must be >= 0 (seconds)")
        self.base_url = base_url.rstrip("/")
        self.api = self.base_url + "/api/v1"
        self.retries = int(retries)
        self.backoff = float(backoff)
        self.max_backoff = float(max_backoff)
        self._sleep = sleep
        headers = {"Accept": "application/json, application/problem+json"}
        if api_key:
            headers["Authorization"] = f"Bearer {api_key}"
        self._http = httpx.Client(headers=headers, timeout=timeout, transport=transport)
        self.requests_sent = 0  # HTTP requests including retries (for diagnostics)
        self.retried = 0

    # ---- plumbing ---------------------------------------------------------------------------------
    def close(self) -> None:
        """Close the connection pool."""
        self._http.close()

    def __enter__(self) -> RomamsClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _delay(self, attempt: int, response: httpx.Response | None = None) -> float:
        """Backoff before retry number ``attempt`` (0-based), at least the server's Retry-After (s)."""
        wait = min(self.backoff * 2.0**attempt, self.max_backoff)
        if response is not None:
            try:
                wait = max(wait, min(float(response.headers.get("retry-after", 0.0)), 60.0))
            except ValueError:  # an HTTP-date Retry-After: use our own backoff
                pass
        return wait

    def request(self, method: str, path: str, *, json: Any = None, params: Mapping[str, Any] | None = None,
                accept: Sequence[int] = (200, 201, 202), files: Mapping[str, Any] | None = None,
                data: Mapping[str, str] | None = None) -> httpx.Response:
        """Send one API request (path relative to /api/v1), retrying transient failures; RomamsError otherwise.
        ``files``/``data``: a multipart upload (httpx's arguments)."""
        url = self.api + path
        for attempt in range(self.retries + 1):
            self.requests_sent += 1
            try:
                r = self._http.request(method, url, json=json, params=params, files=files, data=data)
            except RETRY_EXCEPTIONS as exc:
                if attempt == self.retries:
                    raise RomamsError(0, "Connection failed", f"{method} {url}: {type(exc).__name__}: {exc} "
                                      f"(after {self.retries} retries)") from exc
                self.retried += 1
                self._sleep(self._delay(attempt))
                continue
            if r.status_code in RETRY_STATUSES and attempt < self.retries:
                self.retried += 1
                self._sleep(self._delay(attempt, r))
                continue
            break
        if r.status_code not in accept:
            try:
                body = r.json()
            except ValueError:
                body = None
            raise RomamsError.from_response(r.status_code, body, r.text)
        return r

    def _json(self, method: str, path: str, **kw: Any) -> Any:
        """Request and decode the JSON body."""
        return self.request(method, path, **kw).json()

    @staticmethod
    def _ref(wing: WingRef) -> str:
        """URL path segment of a wing id or name."""
        return quote(str(wing), safe="")

    # ---- wings ------------------------------------------------------------------------------------
    def health(self) -> dict[str, Any]:
        """Service liveness and database kind."""
        return self._json("GET", "/health")

    def create_wing(self, template: str | None = "cropped-delta", name: str | None = None,
                    definition: Mapping[str, Any] | None = None) -> int:
        """Create a wing from a template (or a full definition dict); returns its id."""
        body: dict[str, Any] = {"template": template} if definition is None else {"definition": dict(definition)}
        if name is not None:
            body["name"] = name
        return int(self._json("POST", "/wings", json=body)["id"])

    def get_wing(self, wing: WingRef) -> dict[str, Any]:
        """A wing by id or name: design variables (name, lower, upper, unit), bases, trained Machs."""
        return self._json("GET", f"/wings/{self._ref(wing)}")

    def list_wings(self) -> list[dict[str, Any]]:
        """All wings of the service."""
        return self._json("GET", "/wings")

    def ensure_wing(self, name: str, template: str = "cropped-delta") -> int:
        """Id of the wing called ``name``, created from ``template`` when it does not exist yet."""
        try:
            return int(self.get_wing(name)["id"])
        except RomamsError as exc:
            if exc.status != 404:
                raise
        try:
            return self.create_wing(template, name)
        except RomamsError as exc:  # created concurrently by someone else
            if exc.status != 409:
                raise
            return int(self.get_wing(name)["id"])

    # ---- bases and ROMs ---------------------------------------------------------------------------
    def start_basis(self, wing: WingRef, samples: int = 25, modes: int = 4, mac_threshold: float = 0.98,
                    seed: int = 0, max_basis: int = 12) -> str:
        """Start a basis job (LHS samples x modal analyses -> PCA basis); returns the job id."""
        body = {"samples": int(samples), "modes": int(modes), "mac_threshold": float(mac_threshold),
                "seed": int(seed), "max_basis": int(max_basis)}
        return str(self._json("POST", f"/wings/{self._ref(wing)}/basis", json=body)["job_id"])

    def list_bases(self, wing: WingRef) -> list[dict[str, Any]]:
        """Bases of a wing, newest first."""
        return self._json("GET", f"/wings/{self._ref(wing)}/bases")

    def start_training(self, wing: WingRef, machs: float | Sequence[float], solver: str = "dlm", na: int | None = None,
                       nb: int | None = None, basis_id: int | None = None,
                       options: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
        """Start ROM training at one or several Mach numbers (one job each).

        ``solver``: "dlm" (doublet lattice, rational-function ROM; the default), "uvlm" or "tsd" (ARX ROMs, whose
        orders ``na``/``nb`` apply; None: the server's default for the solver).
        Returns one item per Mach: ``{"mach", "job_id", "rom_id", "existing"}``
        (an already trained model or running job is returned instead of a new one).
        """
        single = np.ndim(machs) == 0
        body: dict[str, Any] = {"solver": solver}
        body.update({k: int(v) for k, v in (("na", na), ("nb", nb)) if v is not None})
        if single:
            body["mach"] = float(machs)  # type: ignore[arg-type]
        else:
            body["machs"] = [float(m) for m in machs]  # type: ignore[union-attr]
        if basis_id is not None:
            body["basis_id"] = int(basis_id)
        if options:
            body["options"] = dict(options)
        out = self._json("POST", f"/wings/{self._ref(wing)}/roms", json=body)
        if single:
            return [out]
        items = out.get("items")
        if items is None:
            items = [{"mach": float(m), "job_id": j} for m, j in zip(body["machs"], out["job_ids"], strict=True)]
        return list(items)

    def list_roms(self, wing: WingRef, basis_id: int | None = None) -> list[dict[str, Any]]:
        """Trained ROMs of a wing (Mach, solver settings, validation error)."""
        params = {"basis_id": int(basis_id)} if basis_id is not None else None
        return self._json("GET", f"/wings/{self._ref(wing)}/roms", params=params)

    # ---- jobs -------------------------------------------------------------------------------------
    def get_job(self, job_id: str) -> dict[str, Any]:
        """One job: status, progress 0..1, message, result, error."""
        return self._json("GET", f"/jobs/{quote(str(job_id), safe='')}")

    def list_jobs(self, status: str | None = None, kind: str | None = None, limit: int = 50) -> list[dict[str, Any]]:
        """Newest jobs first."""
        params: dict[str, Any] = {"limit": int(limit)}
        if status:
            params["status"] = status
        if kind:
            params["kind"] = kind
        return self._json("GET", "/jobs", params=params)

    def cancel_job(self, job_id: str) -> dict[str, Any]:
        """Cancel a queued or running job; returns the job."""
        return self._json("POST", f"/jobs/{quote(str(job_id), safe='')}/cancel")

    def wait_jobs(self, job_ids: Sequence[str | Mapping[str, Any]], timeout_s: float | None = None,
                  poll_s: float = 0.5, progress: bool = True, desc: str = "jobs", raise_on_error: bool = True
                  ) -> list[dict[str, Any]]:
        """Wait until every job is final (ids or start_training items); a tqdm bar shows the mean progress.

        Raises JobError for the first failed/cancelled job (unless ``raise_on_error`` is False) and
        JobTimeout when ``timeout_s`` passes first.
        """
        ids = [str(j["job_id"]) if isinstance(j, Mapping) else str(j) for j in job_ids]
        deadline = None if timeout_s is None else time.monotonic() + float(timeout_s)
        done: dict[str, dict[str, Any]] = {}
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(ids), desc=desc, unit="job", bar_format="{l_bar}{bar}| {n:.2f}/{total} [{elapsed}]"
                       " {postfix}")
        try:
            while True:
                current: dict[str, dict[str, Any]] = {}
                for jid in ids:
                    current[jid] = done[jid] if jid in done else self.get_job(jid)
                    if current[jid]["status"] in FINAL_STATUSES:
                        done[jid] = current[jid]
                if bar is not None:
                    total = sum(1.0 if j["status"] in FINAL_STATUSES else float(j.get("progress") or 0.0)
                                for j in current.values())
                    bar.n = total
                    last = next((j for j in current.values() if j["status"] not in FINAL_STATUSES), None)
                    bar.set_postfix_str((last or {}).get("message", "done")[:60], refresh=False)
                    bar.refresh()
                if len(done) == len(ids):
                    break
                if deadline is not None and time.monotonic() > deadline:
                    pending = next(j for j in current.values() if j["status"] not in FINAL_STATUSES)
                    raise JobTimeout(pending, float(timeout_s or 0.0))
                time.sleep(poll_s)
        finally:
            if bar is not None:
                bar.close()
        jobs = [done[j] for j in ids]
        if raise_on_error:
            for j in jobs:
                if j["status"] != "succeeded":
                    raise JobError(j)
        return jobs

    def wait_job(self, job_id: str, timeout_s: float | None = None, poll_s: float = 0.5, progress: bool = True,
                 desc: str | None = None) -> dict[str, Any]:
        """Wait for one job to succeed (tqdm progress bar); returns the job. JobError if it failed or was cancelled."""
        return self.wait_jobs([job_id], timeout_s, poll_s, progress, desc or f"job {str(job_id)[:8]}")[0]

    def basis_shapes(self, basis_id: int) -> dict[str, np.ndarray]:
        """A basis as arrays, for an aerodynamic code of your own: x, y (standard-mesh nodes, m), shapes
        [n_nodes, m] (out-of-plane displacement, m, +z up, in the basis' order), c_ref (m)."""
        import io

        content = self.request("GET", f"/bases/{int(basis_id)}/shapes.npz").content
        with np.load(io.BytesIO(content)) as z:
            return {k: z[k] for k in z.files}

    def import_gaf(self, wing: WingRef, table: bytes | str | Path, label: str, *, mach: float | None = None,
                   basis_id: int | None = None, n_lags: int | None = None, filename: str | None = None,
                   k_values: Sequence[float] | None = None, matrix: str | None = None,
                   mach_index: int | None = None, skip_modes: int | None = None, refc: float | None = None
                   ) -> dict[str, Any]:
        """Upload a GAF table computed on the basis shapes (NPZ: k, gaf_real, gaf_imag [nk, m, m], mach; CSV
        k,row,col,real,imag with ``mach``; or Nastran's QHH from an OUTPUT4 (.op4) or punch (.pch) file with
        ``mach`` and ``k_values``, the MKAERO1 k list, and optionally ``matrix``, ``mach_index``, ``skip_modes``,
        ``refc`` (m); bytes or a file path) as the ROM of solver ``external:<label>``; returns the ROM. Flutter
        requests use it with ``solver="external:<label>"`` (docs: Your own GAF tables)."""
        if isinstance(table, bytes):
            data, name = table, filename or "table.npz"
        else:
            path = Path(table)
            data, name = path.read_bytes(), filename or path.name
        fields = {"label": str(label)}
        if mach is not None:
            fields["mach"] = repr(float(mach))
        if basis_id is not None:
            fields["basis_id"] = str(int(basis_id))
        if n_lags is not None:
            fields["n_lags"] = str(int(n_lags))
        if k_values is not None:
            fields["k_values"] = ",".join(repr(float(k)) for k in k_values)
        if matrix is not None:
            fields["matrix"] = str(matrix)
        for key, value in (("mach_index", mach_index), ("skip_modes", skip_modes)):
            if value is not None:
                fields[key] = str(int(value))
        if refc is not None:
            fields["refc"] = repr(float(refc))
        return self.request("POST", f"/wings/{self._ref(wing)}/roms/gaf", files={"file": (name, data)},
                            data=fields).json()

    def train(self, wing: WingRef, machs: float | Sequence[float], *, timeout_s: float | None = None,
              progress: bool = True, **kw: Any) -> list[dict[str, Any]]:
        """Start training at ``machs`` and wait for every job; returns the ROM rows this call trained or found."""
        items = self.start_training(wing, machs, **kw)
        pending = [i for i in items if i.get("job_id") and not i.get("rom_id")]
        if pending:
            self.wait_jobs(pending, timeout_s, progress=progress, desc="training")
        wanted = {round(float(i["mach"]), 6) for i in items}
        rows = [r for r in self.list_roms(wing, kw.get("basis_id")) if round(float(r["mach"]), 6) in wanted]
        rom_ids = {i["rom_id"] for i in items if i.get("rom_id") is not None}
        job_ids = {str(i["job_id"]) for i in items if i.get("job_id")}
        mine = [r for r in rows if r["id"] in rom_ids or str(r.get("job_id")) in job_ids]
        return mine or rows  # the ROMs of this call (not older bases' or other solvers' at the same Machs)

    # ---- flutter ----------------------------------------------------------------------------------
    def _job_result(self, body: dict[str, Any], timeout_s: float | None, progress: bool) -> Any:
        """Result of a 202 answer's job (waits for it)."""
        job = self.wait_job(str(body["job_id"]), timeout_s, poll_s=0.2, progress=progress, desc="evaluation")
        return job["result"]

    def evaluate(self, wing: WingRef, design: DesignLike | None = None, *, machs: Sequence[float] | None = None,
                 method: str = "rom-ams", basis_id: int | None = None, store: bool = True,
                 timeout_s: float | None = None, solver: str | None = None) -> dict[str, Any]:
        """Flutter evaluation of one design (None = the wing's baseline) at the trained (or given) Machs.

        Returns the service's result: mass_kg, frequencies_hz, mac, results per Mach (v_flutter_m_s,
        omega_flutter_rad_s, q_flutter_pa, sdoff, flutter_mode, safe_altitude_m), envelope_ok, ...
        A 202 answer (the service was busy) is waited for transparently. ``solver`` picks the ROMs of one
        aerodynamic solver (default: the service's choice, the dlm ROM where one is trained).
        """
        body = {"design": _design_json(design), "method": method, "store": bool(store),
                **_model_choice(machs, basis_id, solver)}
        r = self.request("POST", f"/wings/{self._ref(wing)}/flutter", json=body)
        out = r.json()
        if r.status_code == 202:
            out = self._job_result(out, timeout_s, progress=False)
        return out

    def evaluate_batch(self, wing: WingRef, designs: Iterable[DesignLike] | np.ndarray, *,
                       machs: Sequence[float] | None = None, basis_id: int | None = None,
                       max_per_request: int = 5000, timeout_s: float | None = None,
                       progress: bool = False, solver: str | None = None, run_id: int | None = None,
                       keep_vg: bool = False) -> list[dict[str, Any]]:
        """Flutter evaluation of many designs, results in order (one dict per design, as evaluate()).

        One request per ``max_per_request`` designs; a large batch the service answers with 202 and a
        job is waited for transparently. A design the structure model rejects gets ``{"error": ...}``.
        ``run_id`` (:meth:`create_run`) stores every design as an evaluation of that run; ``keep_vg`` keeps the
        V-g data of each (by default only a run's new best designs keep them).
        """
        payload = _designs_json(designs)
        if max_per_request < 1:
            raise ValueError(f"max_per_request: must be >= 1, got {max_per_request}")
        results: list[dict[str, Any]] = []
        for start in range(0, len(payload), max_per_request):
            body = {"designs": payload[start:start + max_per_request], **_model_choice(machs, basis_id, solver)}
            if run_id is not None:
                body["run_id"] = int(run_id)
                body["keep_vg"] = bool(keep_vg)
            r = self.request("POST", f"/wings/{self._ref(wing)}/flutter/batch", json=body)
            out = r.json()
            if r.status_code == 202 or "results" not in out:
                out = self._job_result(out, timeout_s, progress)
            results.extend(out["results"])
        if len(results) != len(payload):
            raise RomamsError(0, "Bad batch answer", f"expected {len(payload)} results, got {len(results)}")
        return results

    # ---- runs -------------------------------------------------------------------------------------
    def create_run(self, name: str, wing: WingRef | None = None, **settings: float | str) -> dict[str, Any]:
        """Create a run (study) grouping the evaluations of one campaign; ``settings``: mu_kg, mac_threshold,
        envelope_tol_m (its feasibility rule) and penalty ("binary" or "graded"). Returns the run with its ``id``."""
        body: dict[str, Any] = {"name": str(name), **{k: v if isinstance(v, str) else float(v)
                                                       for k, v in settings.items()}}
        if wing is not None:
            body["wing"] = wing
        return self._json("POST", "/runs", json=body)

    def get_run(self, run_id: int) -> dict[str, Any]:
        """A run's summary: counts of evaluations (feasible, infeasible, failed), best design so far, status."""
        return self._json("GET", f"/runs/{int(run_id)}")

    def run_evaluations(self, run_id: int, after_id: int = 0, limit: int = 1000) -> dict[str, Any]:
        """A run's stored evaluations with id > ``after_id``."""
        return self._json("GET", f"/runs/{int(run_id)}/evaluations", params={"after_id": int(after_id),
                                                                               "limit": int(limit)})

    def vg_data(self, evaluation_id: int) -> dict[str, Any]:
        """V-g / V-omega data of a stored evaluation: per Mach, speeds (m/s), damping g and omega (rad/s)."""
        return self._json("GET", f"/evaluations/{int(evaluation_id)}/vg")

    def plot(self, evaluation_id: int, fmt: str = "png", kind: str = "vg", *, axis: str = "tas",
             mach: float | None = None) -> bytes:
        """PNG/SVG bytes of a stored evaluation's V-g plot (kind="vg") or envelope plot (kind="envelope").

        ``axis``: speed axis of the V-g plot, "tas" (true airspeed), "eas" (equivalent airspeed) or "q" (dynamic
        pressure); ``mach``: which Mach's V-g plot (default: the first)."""
        if fmt not in ("png", "svg"):
            raise ValueError(f"fmt: must be 'png' or 'svg', got {fmt!r}")
        if axis not in ("tas", "eas", "q"):
            raise ValueError(f"axis: must be 'tas', 'eas' or 'q', got {axis!r}")
        params: dict[str, Any] = {"kind": kind, "axis": axis}
        if mach is not None:
            params["mach"] = float(mach)
        return self.request("GET", f"/evaluations/{int(evaluation_id)}/plot.{fmt}", params=params).content

    def get_evaluation(self, evaluation_id: int) -> dict[str, Any]:
        """A stored evaluation (request and summary)."""
        return self._json("GET", f"/evaluations/{int(evaluation_id)}")
