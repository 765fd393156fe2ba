"""The study tools: benchmarks beside REBOUND (bench), the work-precision study (tradeoff),
the reference problems (validate) and sp.recommend. They use the World's public API and one
World -> REBOUND adapter (rebound.py)."""
