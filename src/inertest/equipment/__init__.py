"""Test-equipment kinematics: instrument attitude, angular rate and specific force on its axes."""
