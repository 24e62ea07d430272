"""The calibration: a frozen record of one arm's sensing map, offsets and limits, its JSON file, and tare.

- :class:`Calibration` (:mod:`.file`): the data, ``Calibration.load`` / ``save`` and its estimate;
  the file format is ``calibration.schema.json``;
- :func:`tare` (:mod:`.tare`): new zero offsets from readings with nothing touching the handle.

Fitting one lives in :mod:`sailforce.fit`, the run-time estimate in
:mod:`sailforce.estimate`, the C header in :mod:`sailforce.export_c`.
"""

from .file import Calibration, CalibrationFileError, checksum
from .tare import Tare, tare

__all__ = ["Calibration", "CalibrationFileError", "Tare", "checksum", "tare"]
