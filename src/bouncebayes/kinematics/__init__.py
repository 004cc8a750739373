"""Tracked trajectories -> incidence and rebound kinematics of every bounce -> the trial table.

A user films a ball bouncing on a plane (100 Hz - 10 kHz), tracks its centre (the package's
tracker, Tracker, or any other) and exports one file per ball track; a file may hold several
bounces. For each bounce this module fits the free flight before and after the impact
(constant acceleration or quadratic air drag), evaluates both fits at the impact and returns
the incidence and rebound speed and angle with standard errors, after quality gates; or a
:class:`TrajectoryError` that names the file (``<file>#<k>`` for bounce ``k``) and says why it
could not be used.

Frame and signs: ``x`` along the plane in the direction of incident travel, ``y`` along the
outward normal, metres and seconds. Angles are measured from the normal, in degrees:
incidence ``atan2(v_x, |v_y|)`` with ``v_y < 0``; rebound ``atan2(v_x, |v_y|)`` with ``v_y > 0``,
positive when the ball keeps moving forward (+x). With a ``z`` column, (x, z) span the plane and
the velocities are projected onto the plane of incidence.

Pipeline: :func:`read_trajectory` (parse, clean rows, check units, scale, rotate, flip) ->
:func:`fit_bounces` (detect the impacts, fit the flights, delta-method errors, gates) ->
:func:`write_trial_table` (``bouncebayes.data.write_trials``, read by
``bouncebayes.data.load_trials``); :func:`kinematics_from_folder` runs a folder (with an
optional ``spin.csv`` of measured spins), :func:`trial_table_from_folder` the whole step for an
experiment. :func:`write_trajectory` writes the trajectory format the reader reads.

Scale: each bounce's :class:`Fall` (its flights' fitted acceleration, drag added back where the
ball is known) and :func:`gravity_scale` (the campaign's, against ``g``) measure the length
scale independently of the tracker's calibration; :func:`trial_table_from_folder` checks the
one against the other and, with ``scale = "gravity"`` in [trajectories], corrects the lengths.
"""

from ..data import write_trajectory as write_trajectory
from ._clean import OUTLIER_NOISE_SD as OUTLIER_NOISE_SD
from ._clean import REPEAT_AGREEMENT_SD as REPEAT_AGREEMENT_SD
from ._clean import SAMPLE_INTERVAL_RANGE as SAMPLE_INTERVAL_RANGE
from ._clean import SPEED_RANGE as SPEED_RANGE
from ._config import DRAG_MODELS as DRAG_MODELS
from ._config import Drag as Drag
from ._config import FitConfig as FitConfig
from ._contact import refer_to_contact as refer_to_contact
from ._fit import PROMINENCE_IN_NOISE_SD as PROMINENCE_IN_NOISE_SD
from ._fit import find_bounces as find_bounces
from ._fit import fit_bounces as fit_bounces
from ._fit import fit_kinematics as fit_kinematics
from ._flight import DRAG_MIN_POINTS as DRAG_MIN_POINTS
from ._gravity import Fall as Fall
from ._gravity import GravityScale as GravityScale
from ._gravity import gravity_scale as gravity_scale
from ._folder import FolderKinematics as FolderKinematics
from ._folder import rescaled_by_fall as rescaled_by_fall
from ._folder import ball_drag as ball_drag
from ._folder import kinematics_from_folder as kinematics_from_folder
from ._folder import trial_table_from_folder as trial_table_from_folder
from ._folder import trials_from_kinematics as trials_from_kinematics
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
from ._spin import SPIN_FILE as SPIN_FILE
from ._spin import read_spin_table as read_spin_table

__all__ = ["DRAG_MIN_POINTS", "DRAG_MODELS", "LENGTH_UNITS", "MIN_TRACKED_POINTS",
           "OUTLIER_NOISE_SD", "PROMINENCE_IN_NOISE_SD", "REPEAT_AGREEMENT_SD",
           "SAMPLE_INTERVAL_RANGE", "SPEED_RANGE", "SPIN_FILE", "TRIAL_TABLE_COLUMNS", "Drag",
           "FailureReason", "Fall", "FitConfig", "FolderKinematics", "GravityScale", "ball_drag",
           "Kinematics", "LengthUnit", "Trajectory", "TrajectoryError", "find_bounces",
           "fit_bounces", "fit_kinematics", "gravity_scale", "kinematics_from_folder",
           "read_spin_table", "read_trajectory", "refer_to_contact", "rescaled_by_fall",
           "trajectory_from_arrays", "trial_table_from_folder", "trials_from_kinematics",
           "write_trajectory", "write_trial_table"]
