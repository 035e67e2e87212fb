"""Optimizers for VMD parameters: SABO as an Optuna sampler."""
