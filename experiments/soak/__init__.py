"""Soak runs: a long run under seeded faults, its invariants and its report."""
