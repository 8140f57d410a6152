"""Inertial navigation error analysis (seed 002).

The static-base error model, its exact propagation, covariance of random sources, closed forms
and TOML scenarios.
"""
