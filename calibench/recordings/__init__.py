"""Recordings: what an instrument records, the one interface between world and algorithms.

Simulated and real recordings load into the same small dataclasses of numpy arrays, with units
in the field names. Truth never goes in here. This package sits outside the four rooms and needs
only numpy (and scipy's rotations for a Stewart pose's Euler angles): a user with real data loads
a recording without importing the simulation.

- ``records``: the recording types and how each writes its CSV;
- ``csv_io``: the CSV reader every format shares (its checks: encoding, separators, columns,
  numbers, row caps, line numbers in every message) and the writer;
- ``stage``, ``arm``, ``scanner``, ``stewart``, ``axis_run``: each format's loader and its checks.
"""

from calibench.files import same_file
from calibench.recordings.arm import ARM_OPTIONAL, ARM_REQUIRED, MAX_STD_MM, load_arm_csv
from calibench.recordings.axis_run import load_axis_run
from calibench.recordings.csv_io import RecordingError, read_columns, write_csv
from calibench.recordings.records import (
    STEWART_POSE,
    ArmRecording,
    AxisRun,
    CameraViews,
    ScannerRecording,
    StageRecording,
    StewartRecording,
)
from calibench.recordings.scanner import MAX_RHO_MM, load_scanner_csv
from calibench.recordings.stage import MAX_STAGE_MM, load_stage_csv
from calibench.recordings.stewart import load_stewart_csv

__all__ = [
    "ARM_OPTIONAL",
    "ARM_REQUIRED",
    "MAX_RHO_MM",
    "MAX_STAGE_MM",
    "MAX_STD_MM",
    "STEWART_POSE",
    "ArmRecording",
    "AxisRun",
    "CameraViews",
    "RecordingError",
    "ScannerRecording",
    "StageRecording",
    "StewartRecording",
    "load_arm_csv",
    "load_axis_run",
    "load_scanner_csv",
    "load_stage_csv",
    "load_stewart_csv",
    "read_columns",
    "same_file",
    "write_csv",
]
