"""Tracked trajectories -> incidence and rebound kinematics of one bounce per file (MODEL.md §4).

A user films a ball bouncing on a plane (100 Hz - 10 kHz), tracks its centre (Tracker or any
tracker) and exports one file per bounce. For each file this module fits the free flight before
and after the impact with constant acceleration, evaluates both fits at the impact and returns
the incidence and rebound speed and angle with standard errors, or a :class:`TrajectoryError`
that names the file and says why it could not be used.

Frame and signs (MODEL.md §1): ``x`` along the plane in the direction of incident travel, ``y``
along the outward normal, metres and seconds. Angles are measured from the normal, in degrees:
incidence ``atan2(v_x, |v_y|)`` with ``v_y < 0``; rebound ``atan2(v_x, |v_y|)`` with ``v_y > 0``,
positive when the ball keeps moving forward (+x). With a ``z`` column, (x, z) span the plane and
the velocities are projected onto the plane of incidence (see :func:`fit_kinematics`).

Pipeline: :func:`read_trajectory` (parse, scale, rotate, flip) -> :func:`fit_kinematics`
(detect the impact, fit the segments, delta-method errors) -> :func:`write_trial_table` (the CSV
that ``bouncebayes.data.load_trials`` reads); :func:`kinematics_from_folder` runs a folder.
"""

from ._fit import DRAG_MODELS as DRAG_MODELS
from ._fit import PROMINENCE_IN_NOISE_SD as PROMINENCE_IN_NOISE_SD
from ._fit import Drag as Drag
from ._fit import fit_kinematics as fit_kinematics
from ._folder import FolderKinematics as FolderKinematics
from ._folder import kinematics_from_folder as kinematics_from_folder
from ._folder import refer_to_contact as refer_to_contact
from ._folder import trial_table_from_folder as trial_table_from_folder
from ._folder import write_trial_table as write_trial_table
from ._read import LENGTH_UNITS as LENGTH_UNITS
from ._read import MIN_TRACKED_POINTS as MIN_TRACKED_POINTS
from ._read import LengthUnit as LengthUnit
from ._read import Trajectory as Trajectory
from ._read import read_trajectory as read_trajectory
from ._read import trajectory_from_arrays as trajectory_from_arrays
from ._result import TRIAL_TABLE_COLUMNS as TRIAL_TABLE_COLUMNS
from ._result import FailureReason as FailureReason
from ._result import Kinematics as Kinematics
from ._result import TrajectoryError as TrajectoryError

__all__ = ["DRAG_MODELS", "Drag", "FailureReason", "FolderKinematics", "Kinematics",
           "LENGTH_UNITS", "LengthUnit", "MIN_TRACKED_POINTS", "PROMINENCE_IN_NOISE_SD",
           "TRIAL_TABLE_COLUMNS", "Trajectory", "TrajectoryError", "fit_kinematics",
           "kinematics_from_folder", "read_trajectory", "refer_to_contact",
           "trajectory_from_arrays", "trial_table_from_folder", "write_trial_table"]
