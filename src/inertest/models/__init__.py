"""Instrument error models: regressors Phi(inputs), coefficient names and units."""
