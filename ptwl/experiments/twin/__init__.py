"""The ground twin judged on a virtual clock (ptwl/experiments/twin/trial.py)."""
