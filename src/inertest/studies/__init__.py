"""System and equipment studies: what machine errors and rotation schemes cost.

Not tests of an instrument: the centrifuge error study, rotation modulation of an IMU and of a
gyro's stator.
"""
