"""Calibrating a SAIL arm and estimating force with the result.

- :mod:`.compensation`: the sensing models M(theta1, theta2) (torque scale,
  the seed's amplitude/phase compensator, the Chebyshev matrix model) and
  the matrix model's fit;
- :mod:`.regressors`: the seed's polynomial regressors (Table 4);
- :mod:`.fit`: :func:`fit_calibration`, a model and offsets from calibration data;
- :mod:`.file`: :class:`Calibration`, the frozen result, and its JSON file
  format (``calibration.schema.json``);
- :mod:`.estimator`: the run-time estimate, one status per reading;
- :mod:`.inertial` and :mod:`.motion_stream`: the dynamic term, identified
  and subtracted while the arm moves;
- :mod:`.filters`: the readings' low-pass;
- :mod:`.streaming`: the estimate over files and live streams in chunks;
- :mod:`.export_c`: a calibration as a libsail header.
"""
