"""The errors perception raises: each names what is wrong and, where it can, what to do.

They are RuntimeErrors so that `pete-jetson` prints them as one line instead of a traceback.
"""

from __future__ import annotations


class PerceptionError(RuntimeError):
    """Base of every perception error."""


class SourceError(PerceptionError):
    """A camera, recording or stream that cannot be opened or read."""


class DatasetError(PerceptionError):
    """A dataset folder that is missing, empty or malformed."""


class ModelError(PerceptionError):
    """Detector weights that are missing or unusable."""


class ConfigError(PerceptionError):
    """A configuration value or file that cannot be used."""


class CalibrationError(PerceptionError):
    """Calibration images that do not yield a camera model."""
