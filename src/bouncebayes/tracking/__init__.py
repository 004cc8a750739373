"""Ball tracking in high-speed video: frames -> sub-pixel ball centres -> plane-frame trajectory.

The pipeline, one pure function per stage (paper §3 did this by hand in Tracker):

1. :func:`read_frames`: a video file (mp4, avi, mov, ...) or a folder of image frames, as grey
   ``uint8`` frames plus the frame rate (from the file, or ``fps=`` which always wins: high-speed
   cameras often store a playback rate such as 30 fps rather than the capture rate).
2. :func:`track_ball`: a background model (per-pixel temporal median; of the frames each
   divided by its brightness where a lamp flickers, and moved back onto the background's pixels
   where the camera moved: ``Track.camera_shift``, ``_camera.py``), then in every frame a
   coarse search (downsampled background difference, largest blob) or a search in a window
   around the position predicted from the two previous frames, and a sub-pixel measurement:

   - every pixel gets a *coverage* ``alpha = (I - B) / (F - B)`` clipped to [0, 1], with ``B``
     the background model (scaled by each frame's overall brightness: lamp flicker) and ``F``
     the ball's grey level at its rim. Coverage is immune to a textured background and to the
     surface line (both are in ``B``), and to a shadow: darker than the background, it gets
     ``alpha = 0`` next to a bright ball, and where it runs under the ball's edge ``B`` is
     rescaled by the shadow's depth just outside the ball;
   - a ball wholly in the frame is measured by the coverage centroid (exact for a disk of any
     size and for a motion-blurred disk, whose coverage centroid is the mid-exposure centre for a
     straight path);
   - a ball cut by the frame edge is measured by a least-squares fit of an anti-aliased disk of
     the video's median radius to the coverage of the pixels that are in the frame.

   Frames where no ball is found, or where less than ``min_visible`` of it is in view, or whose
   radius disagrees with the median, are marked (``method == NOT_FOUND``), never interpolated.
   Every found frame gets a quality figure (``Track.residual``: misfit of a disk to its
   coverage; ``Track.visible``) and frames whose residual stands out are flagged
   (``Track.flag``: part of the ball hidden or lost against the background).
   The ball's radius, and so the ``--ball-diameter`` scale, comes from its edge
   (``_edge.py``): a blurred, shaded sphere fitted to ~9 frames, with the local ball and
   background levels on each side of the edge, the lens blur and the exposure's smear free;
   the median radius and its standard error (``Track.radius_fit``); the sides of the rim
   whose wall is not the background's (a lamp's shadow of the ball on the wall) left out,
   and said. The same fits give the ball's centre, and the coverage centroids are shifted by
   their median difference (a constant bias of the centroid under side light). Frames lost
   or repeated (a camera that drops frames, a file converted to another frame rate) are told
   by the ball's steps (``Track.timing``, ``_timing.py``): each frame's place in the camera's
   sequence, the repeated ones flagged, and said.
3. :class:`Calibration` (metres per pixel, from a reference length or the ball diameter) and
   :class:`Surface` (the surface line, from two points or :func:`detect_surface`); with the
   surface known, frames lost at a bounce are told by where the flights either side meet
   (``_timing.lost_at_bounces``).
4. :func:`to_plane_frame`: ``x`` along the surface in the direction of travel, ``y`` along the
   outward normal (the side of the ball), metres; then :func:`write_track_files`: the
   trajectory (``bouncebayes.data.write_trajectory``, with the per-frame quality columns), the
   record ``<name>.track.json`` (calibration with its relative SD, surface angle with its SD,
   quality summary, settings, version) and :func:`overlay_image`. :func:`track_video` runs
   stages 1-4 for one input (``track`` and ``run`` call it once per video).

Accuracy on the synthetic 1000 fps videos of ``tests/test_tracking.py`` (ball radius 12 px,
textured background, surface line): 0.01 px RMS on clean frames, 0.04 px with full-frame motion
blur, noise of 4 grey levels and a shadow, 0.02 px for a ball cut by the frame edge, 0.05-0.07 px
after MJPG/MPEG-4 compression. The scale on an independent physically based renderer
(``tests/render_pbr.py``; docs/tracking.md): see ``benchmarks/results/tracking_accuracy.json``. The
errors are not white (they follow the background texture under the ball), ~0.05% of the speed
on clean video: below the kinematics' standard errors for noise of a few grey levels, above them
for nearly noise-free video.

Limits: one ball, darker or brighter than its surroundings all round its rim (``polarity``);
grey levels only (colour video is converted to grey: its luma, or the colour channel where the
ball stands out far more clearly, ``read_frames(channel=...)``); a ball radius of at least ~4
px; the ball must move by more than a diameter over the video, or the median background
contains it (give a ``background`` image of the empty scene then); all frames are held in
memory (``n * h * w`` bytes; four times that while a colour video is read).
"""

from ._geometry import Calibration as Calibration
from ._geometry import PlaneTrajectory as PlaneTrajectory
from ._geometry import Surface as Surface
from ._geometry import detect_surface as detect_surface
from ._geometry import plane_axes as plane_axes
from ._geometry import to_plane_frame as to_plane_frame
from ._measure import CENTROID as CENTROID
from ._measure import EDGE_FIT as EDGE_FIT
from ._measure import METHOD_NAMES as METHOD_NAMES
from ._measure import NOT_FOUND as NOT_FOUND
from ._output import PAPER_BALL_DIAMETER as PAPER_BALL_DIAMETER
from ._output import TrackedVideo as TrackedVideo
from ._output import compression_warning as compression_warning
from ._output import radius_warning as radius_warning
from ._output import camera_message as camera_message
from ._output import LENS_MODES as LENS_MODES
from ._output import lens_warning as lens_warning
from ._output import surface_warning as surface_warning
from ._output import cast_message as cast_message
from ._output import depth_warning as depth_warning
from ._output import timing_warning as timing_warning
from ._output import tone_curve_warning as tone_curve_warning
from ._output import overlay_image as overlay_image
from ._output import track_record as track_record
from ._output import track_video as track_video
from ._output import write_track_files as write_track_files
from ._edge import RadiusFit as RadiusFit
from ._track import POLARITIES as POLARITIES
from ._track import Polarity as Polarity
from ._track import Track as Track
from ._track import TrackerConfig as TrackerConfig
from ._track import background_model as background_model
from ._track import track_ball as track_ball
from ._video import CHANNELS as CHANNELS
from ._video import IMAGE_SUFFIXES as IMAGE_SUFFIXES
from ._video import VIDEO_SUFFIXES as VIDEO_SUFFIXES
from ._tone import TONE_CURVES as TONE_CURVES
from ._tone import tone_curve_label as tone_curve_label
from ._video import VideoSource as VideoSource
from ._video import read_frames as read_frames
from ._video import read_image as read_image

__all__ = ["CENTROID", "CHANNELS", "EDGE_FIT", "IMAGE_SUFFIXES", "LENS_MODES", "METHOD_NAMES",
           "NOT_FOUND", "PAPER_BALL_DIAMETER", "POLARITIES", "TONE_CURVES", "VIDEO_SUFFIXES",
           "Calibration",
           "PlaneTrajectory", "Polarity", "RadiusFit", "Surface", "Track", "TrackedVideo",
           "TrackerConfig", "VideoSource", "background_model", "camera_message",
           "cast_message", "compression_warning", "depth_warning", "lens_warning",
           "detect_surface",
           "overlay_image", "plane_axes", "radius_warning", "read_frames", "read_image",
           "surface_warning", "timing_warning", "tone_curve_label", "tone_curve_warning",
           "to_plane_frame",
           "track_ball", "track_record", "track_video", "warm_kernels", "write_track_files"]


def warm_kernels() -> None:
    """Compile (or load from numba's on-disk cache) the tracker's compiled kernels: the
    per-frame path and the edge model (``bouncebayes warmup``, run by ``make install``)."""
    from ._fast import warm

    warm()
