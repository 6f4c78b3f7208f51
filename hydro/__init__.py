"""Per-link hydrodynamics for underwater multibody vehicles (plain numpy)."""
