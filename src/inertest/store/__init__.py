"""Calibration history database."""
