"""The ground twin judged on a virtual clock (experiments/twin/trial.py)."""
