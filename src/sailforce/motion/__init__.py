"""The arm in motion: its dynamics, joint rates from sampled angles, and reaching movements.

- :mod:`.dynamics`: the shear each cell carries from link inertia, gravity
  and the hand's force (:class:`ShearModel`, the base parameters);
- :mod:`.differentiate`: zero-phase joint rates and accelerations from
  encoder angles (Savitzky-Golay windows), in files and live;
- :mod:`.reaching`: minimum-jerk reaches and the recordings they produce.
"""
