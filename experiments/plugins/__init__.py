"""The built-in experiments, one module each: `longterm` and `boxpush`.

The registry of every experiment, installed packages' included, is `experiments.registry`.
"""
