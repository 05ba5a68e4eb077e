"""Bytes per design of a run's compact evaluations, on the configured database (``ROMAMS_DATABASE_URL``), as JSON.

Stores ``--designs`` evaluations of a 7-variable design at ``--machs`` Mach numbers (summaries with the keys and
magnitudes of real ones) through the repository, in chunks of 64 (one INSERT each, as a worker does), and reports
the payload (design vector, flutter rows, error text) per design and, on PostgreSQL, the table's size on disk with
its indexes per design. Usage:
  ROMAMS_DATABASE_URL=postgresql+psycopg://... python -m benchmarks.run_storage [--designs 5000] [--machs 5]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from romams.persistence import open_store
from romams.services.runs import compact_row, run_settings


def summary(rng: np.random.Generator, machs: np.ndarray) -> dict:
    """A design's evaluation summary with realistic values (kg, m, m/s, Hz)."""
    margin = rng.normal(0.0, 800.0, machs.size)
    return {"mass_kg": 0.17 + 0.1 * rng.random(), "mac": (1 - 1e-3 * rng.random(4)).tolist(), "sdoff": False,
            "envelope_ok": bool(np.all(margin >= 0)), "envelope_margin_m": margin.tolist(),
            "results": [{"mach": float(m), "v_eas_m_s": 150 + 60 * rng.random(), "frequency_hz": 20 + 10 * rng.random(),
                         "flutter_mode": 2, "safe_altitude_m": 9000 + 4000 * rng.random(), "sdoff": False}
                        for m in machs]}


def main() -> None:
    """Store the designs and print the sizes."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--designs", type=int, default=5000)
    ap.add_argument("--machs", type=int, default=5)
    args = ap.parse_args()
    store = open_store(migrate=True)
    settings = run_settings(None)
    run_id = store.runs.create("storage benchmark", settings)
    rng = np.random.default_rng(0)
    machs = np.linspace(0.79, 0.95, args.machs)
    for start in range(0, args.designs, 64):
        rows = [compact_row(rng.random(7).tolist(), summary(rng, machs), settings, "job")
                for _ in range(min(64, args.designs - start))]
        with store.unit_of_work() as uow:
            uow.runs.add_evaluations(run_id, rows)
    out = {"designs": args.designs, "machs": args.machs, "dialect": store.engine.dialect.name,
           "payload_bytes_per_design": store.runs.counts(run_id)["payload_bytes"] / args.designs}
    rows, size = store.runs.table_size()
    if size is not None:  # PostgreSQL: the table on disk, every run in it
        out["table_bytes_per_design"] = size / rows
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
