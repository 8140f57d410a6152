"""System-level analyses: INS error propagation, rotation modulation."""
