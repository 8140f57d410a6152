"""Least squares with covariance, identifiability, harmonic fits."""
