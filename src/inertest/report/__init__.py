"""Figures (matplotlib, Agg backend) and self-contained HTML reports."""
