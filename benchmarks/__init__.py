"""Speed and accuracy benchmarks; each prints JSON (run: python -m benchmarks.run --json)."""
