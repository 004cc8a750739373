"""The ball's radius from its edge: a blurred, shaded sphere fitted to the pixels of its rim.

Each pixel ``i`` near the ball is described by its distance ``rho_i`` from the ball's centre and
its polar angle ``t_i``; ``u_i = r - rho_i`` is its depth inside the rim. The grey level is the
background ``B`` where the ball does not cover it and the ball's radiance where it does, both
blurred::

    I_i = B_i (1 - S_i) - k grad B_i . grad S_i + sum_j beta_j f_j(u_i, t_i)
          + (1 - S_i) (o_0 + o_1 cos t + o_2 sin t)

- ``S = E[1{u + e > 0}] = Phi(u / s)``, ``e ~ N(0, s_i^2)``: the blurred step of the rim, with
  ``s_i^2 = sigma^2 + 1/12 + (a v)^2 cos^2(t_i - t_v) / 12``: a Gaussian lens blur, the pixel's
  own width, and the exposure's smear along the ball's direction of motion (``a`` the exposure
  as a fraction of the frame interval, ``v`` the ball's speed in px per frame);
- the wall the ball hides: the ball covers the wall before the lens blurs it, and ``- k grad B
  . grad S`` (``k = sigma^2 + 1/12``) is that to first order in the wall's gradient
  (:func:`._edge_kernel._row`; not for a ball under ``OCCLUSION_MIN_RADIUS``);
- the edge's curvature: blur along the rim moves the half-level inwards by ``s_t^2 / (2 r)``
  (``s_t`` the blur along the tangent), so the step sits at ``r - s_t^2 / (2 r)``;
- the ball's radiance ``f_j``: the nine spherical harmonics of the surface normal up to order 2
  (``1, n_x, n_y, n_z, n_x n_y, n_x^2 - n_y^2, n_x n_z, n_y n_z, n_z^2``), which hold Lambert
  shading under any distant lighting to ~2 % (Ramamoorthi & Hanrahan 2001; Basri & Jacobs
  2003), limb darkening and side light included, plus the rim level's harmonics of order 2 to
  ``RIM_ORDER`` in ``t``; each blurred in closed form (``n_z = sqrt(u (2r - u)) / r``:
  ``E[sqrt(u + e)_+]`` from the parabolic cylinder function, tabulated once; ``E[(u + e)_+]``
  and ``E[(u + e)^2_+]`` exact);
- the shadow of a distant light (:func:`._edge_kernel._shadow`): Lambert shading is
  ``max(0, n . L) = n . L - min(0, n . L)``; the harmonics hold the first part, not the
  second, which they smoothed over on a ball lit from the side (+1.6 % in the radius at a
  1.5 px blur). Two more columns, ``min(0, n . L)`` and ``n_z min(0, n . L)`` (Lambert
  times linear limb darkening), blurred along the radius by quadrature, with the light's
  azimuth and elevation two more nonlinear parameters (started from a grid after a fit
  without them; held at the first fits' direction that fits their frames best together,
  one lamp per video). Balls under ``SHADOW_MIN_RADIUS`` get none, nor frames where it
  lowers the cost by less than ``SHADOW_MIN_GAIN`` residual variances or the blur exceeds
  ``SHADOW_MAX_BLUR`` of the radius, nor videos where most first fits have none (but a
  blurred ball's frames fitted together look for it again, :func:`joint_radius`);
- the local background level on each side (``o``): a shadow, flicker; the polar sectors whose
  wall beyond the rim is not the background's (a lamp's shadow of the ball) are left out
  (:func:`._edge_kernel.foreign_sectors`), and where frames are fitted together each frame's
  shading is scaled by how brightly the ball is lit there (:func:`_ball_levels`).

So the ball and background levels on each side of the edge are fitted, never assumed. For each
``(c, r, sigma, a, az, el)`` the linear coefficients are solved by least squares (variable
projection), and those seven by a compiled Levenberg-Marquardt within bounds
(:func:`._edge_kernel.fit_frame`, on the residual's analytic Jacobian from the same compiled
call, :func:`._edge_kernel.varpro`) from the best point of a grid
of radius and blur (the model has local minima where blur trades against the shading near the
rim). Saturated pixels (a specular highlight) are left out, and pixels the smooth model cannot
follow (a highlight's lobe, texture on the ball) are down-weighted in a second pass. Each
residual is divided by its SD where the background shows through (the background model is a
median of a few dozen frames and carries their noise; :func:`._edge_kernel.varpro`).
:func:`fit_radius` fits 5 frames alone, then 9 again with the blur and exposure held at their
medians (shared by the video: one lens, one exposure), and takes the median radius; 13 and 25
where the ball is blurred by ``BLURRED`` of its radius or more, and there the radius is the one
that fits those frames together, one shading, blur and light for all (:func:`joint_radius`).
Where the frames are fitted together (:func:`joint_radius`) the columns are blurred in two
dimensions instead (``exact``, :func:`._edge_kernel._hankel`): the blur of ``g(rho) cos(m t)``
by quadrature of its Bessel kernel, which the closed forms above approximate (a blur along the
radius only, and products of blurred factors for ``n_x n_z``, ``n_y n_z``); they were off by
up to 13 % of ``n_x n_z``'s largest value and 40 % of the rim's fourth harmonic's under a
1.5 px blur of a 10 px ball, and a limb-darkened ball's radius by -0.8 % (noise-free).
Written here because no library fits a blurred, shaded disk.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from ._cast import CastShadow, at_centres, find_cast, painted

RIM_ORDER = 4      # harmonics of the rim level in the polar angle
INNER = 0.3        # pixels deeper than INNER r inside the rim are not fitted (beyond 2.5 blurs)
MAX_FRAMES = 9     # frames fitted per video (blur and exposure held)
FIRST_FRAMES = 5   # of which fitted with blur and exposure free
# ... and where those free fits find a blur of at least BLURRED of the radius, up to
# MAX_FRAMES_BLURRED frames, FIRST_FRAMES_BLURRED of them free. There the radius trades against
# the blur (a 10 px ball blurred by 1.5 px: -4 px of radius per px of blur), so the blur the
# fits hold, the median of the free fits', sets the radius' error: over three seeds of
# benchmarks/tracking_accuracy.py's scenes at radius 10-15 px (blur 0.7 and 1.5 px; 81 scenes;
# 2026-11-28) 42 within 0.5 % with 9 / 5 frames, 46 with 17 / 9 and 52 with 25 / 13 (RMS
# error at 15 px and blur 1.5 px 1.21 -> 0.57 %), at 2.5x the edge model's CPU time there.
# A small ball's blur, held by the small-ball fit (._refine), too: radius 5 px, blur 0.7 px
# (27 scenes) within 2 % 20 -> 26, RMS 1.3 -> 0.9 %; the paper's camera (32 clips,
# benchmarks/paper_camera.py) centres within 0.15 px 31 -> 32, the scale's RMS error 2.0 ->
# 1.6 %; its 224 x 64 benchmark video 85 -> 105 CPU-us a frame where it applies. Not above a
# blur of MORE_FRAMES_MAX_BLUR of the radius: at 5 px under a 1.5 px blur (fitted 0.29-0.35 of
# it) the radius moved by up to 18 % either way, within 2 % 14 -> 11 of 27
BLURRED = 0.05
MORE_FRAMES_MAX_BLUR = 0.2
MAX_FRAMES_BLURRED = 25
FIRST_FRAMES_BLURRED = 13
MAX_PIXELS = 1200  # pixels fitted per frame (a large ball's are thinned)
START_REACH = 7.0  # px beyond 1.25 starting radii that the starting grid reads (_start)
XTOL = FTOL = 1e-4  # the fits' tolerances (as SciPy's least_squares') ...
MAX_NFEV = 12       # ... and evaluations per fit (to convergence: no systematic change, 2-5x
#                     the time; docs/tracking.md section 3)
SHADOW_NODES = 12   # quadrature nodes of the shadow columns (._edge_kernel._shadow)
# coverage radius (px) below which the model has no shadow: at 5 px the shadow's crescent is
# a pixel or two wide and its two columns and the light's direction traded against the
# radius (benchmarks/tracking_accuracy.py: 5 px, plain wall, blur 0.7 px: dark ball +3.4 ->
# +6.5 %, MPEG-4 +6.6 -> +10.3 %), and the fits took twice the time (224 x 64 px: 6241 -> 4858
# frames/s, below the target of 5000)
SHADOW_MIN_RADIUS = 8.0
# ... and where it lowers a frame's cost by less than SHADOW_MIN_GAIN times the residual
# variance at the start (fitted without; a chi-square of ~4 degrees of freedom, p ~ 0.005),
# and in a video where most frames have none. Measured (benchmarks/tracking_accuracy.py
# scenes, 5 frames each): side-lit 15 px, blur 1.5 px, plain wall 19-45; side-lit 10 px,
# blur 0.7 px 23-39; glossy 10 px 15-35; but a dark ball (weak shading) 1-12 and a ball lit
# from the camera (no terminator: the columns fit the wall's texture) 3-13, up to 30 at a
# 1.5 px blur, where forced the shadow traded against the radius (lit from the camera, 10 px,
# blur 0.7 px, plain wall: +2.9 %; dark, blur 1.5 px: -1.4 -> -2.4 %)
SHADOW_MIN_GAIN = 15.0
# ... and where the fit without it finds a blur above SHADOW_MAX_BLUR of the radius: the
# shadow's crescent is then within a blur or two of the rim and its columns trade against the
# blurred step (radius 10 px, blur 1.5 px, plain wall: side-lit -1.35 -> +2.47 %, glossy -1.08
# -> -2.92 %; at 15 px, blur 1.5 px, fitted ~0.10 r, it helped: +2.5 -> +1.6 %, +3.6 -> +1.4 %)
SHADOW_MAX_BLUR = 0.125
# ... and on the frames fitted together (joint_radius), where the shadow's columns lower their
# cost by JOINT_SHADOW_MIN_FALL of it or more (the exact columns, the grid of _joint_light).
# Measured (25 frames, radius 10 px; benchmarks/tracking_accuracy.py's scenes, seeds 10-12,
# and those lit from the camera, seeds 10-11): side-lit and glossy balls under a 1.5 px blur
# 0.25-1.6 %; a ball lit from the camera 0.04-0.19 % (a light so found moved the radius by up
# to -0.5 %), a dark ball 0.03-0.06 % under a 1.5 px blur and 0.05-0.19 % under 0.7 px (its
# weak shading does have a light). The columns blurred along the radius only gave all of them
# more (shaded 0.9-7.6 %, lit from the camera up to 0.21 %) and took the threshold 0.6 %
JOINT_SHADOW_MIN_FALL = 0.0022
# The joint fit's last stage leaves out the pixels within SATURATED_REACH blurs of a saturated
# one (joint_radius, where it is measured) ...
SATURATED_REACH = 3.0
# ... and its first stage starts from these radii times the frames' median (joint_radius)
JOINT_STARTS = (0.96, 1.0, 1.04)
# The frames together share one shading (one lamp, far away). A ball whose look changes from
# frame to frame breaks that: a dark spot near its rim turning with it (a logo;
# tests/render_pbr.py's ``spot``, 0.5 rad, 10 px, blur 0.7 px) took the joint fit's blur from
# the frames' 0.77 to 1.54 px and its radius 23 % under their median (-15 % against -2.0 %
# for the median; 15 px: -7.3 against -1.5 %). Where the joint blur moves from the frames' by
# more than JOINT_BLUR_AGREE of it, the frames' median and blur are kept. On the 52 joint
# fits of benchmarks/tracking_accuracy.py it moved by -7.5 to +4.3 % (the radius -3.5 to
# +3.8 %); on the spots that misfit +32 to +100 %, on 0.3-rad spots +7 and +11 % (their
# radius -2.5 % either way)
JOINT_BLUR_AGREE = 0.25
# ... and where the joint fit's RMS residual is JOINT_RMS times the frames' own (their median)
# or more: a logo the frames' own shading takes up, theirs with the sectors it misfits left
# out (fit_edge), but one shading cannot. benchmarks/tracking_centres.py's side-lit 15 px ball
# with a 0.5 rad spot (seed 2): frames 2.9, joint 11.3 grey levels, its radius -2.3 % against
# the frames' -0.7 %; a striped 10 px ball 2.75 and 4.5; a clear glossy one (MJPEG, blur
# 1.5 px) 2.06 and 1.91
JOINT_RMS = 2.5
# A frame's fit (fit_edge) whose rim misfits in a polar sector by more than EDGE_MISFIT of the
# ball's contrast (._edge_kernel.sector_misfit) is fitted again without the run of sectors
# about the worst (._edge_kernel.grow_run, MISFIT_ROUNDS times at most), and the frames fitted
# together leave out each frame's so (_joint_without_misfit): a logo or a stripe near the rim
# takes a bite out of it that the radius follows. The clear balls' fits misfit by 0.02-0.10 at
# most in any sector (benchmarks/tracking_accuracy.py's 88 scenes and tracking_centres.py's 48
# clear bounces: every radius unchanged); tracking_centres.py's striped and spotted balls
# (radius 10-15 px, a stripe 0.25 rad wide, spots of 0.3 and 0.5 rad): docs/tracking.md §1.
# (._refine's centres use ._edge_kernel.MISFIT_SECTOR, 0.2; the radius gained more at 0.12)
EDGE_MISFIT = 0.12
# The wall's occlusion term (._edge_kernel._row: the ball hides the wall before the lens blurs
# it, so the image is B (1 - S) - k grad B . grad S to first order in the wall's gradient) only
# for a ball of at least OCCLUSION_MIN_RADIUS px (the fits' current radius). Measured over
# three seeds of benchmarks/tracking_accuracy.py's scenes (blur 0.7 and 1.5 px, 2026-11-28):
# at 10-15 px on a textured wall the radius' mean error under a 1.5 px blur -0.78 -> +0.15 %
# (10 px) and within 0.5 % 16 of 36 -> 20; a dark 10 px ball, noise-free, -0.8..-1.4 % ->
# -0.4..+0.3 %. At 5 px, where it only moves the blur and exposure that the small-ball fit
# holds, the radius under a 1.5 px blur got worse (within 2 %: 14 of 27 -> 9; dark balls 9 of
# 9 -> 5): there the wall under the kernel is not near its first-order expansion. But a small
# ball's frames fitted together with the blur free (_small_blur_free) take it at any size:
# without it, noise-free on the textured wall (tests/render_pbr.py, 5 px, blur 1.5 px, 25
# frames, the true centres to start), a uniform black ball came out -3.5 %, side-lit -3.7 %,
# with it +0.1 and -0.03 % (a uniform disk on a plain wall, exact: +0.2 % without it); the
# sweep's worst scenes with noise -3.2..-2.1 % -> -0.8..+0.1 % (docs/tracking.md §3)
OCCLUSION_MIN_RADIUS = 8.0


# Systematic error of the edge model's radius, px, added in quadrature to the scatter across
# frames: SYSTEMATIC_PX, plus a term that grows steeply with the blur (there blur trades
# against the shading near the rim): BLUR_PX3 * sigma^3 (px, sigma the fitted blur in px).
# Both set from the sweep of benchmarks/tracking_accuracy.py (docs/tracking.md §3), textured
# and plain walls: errors up to ~0.05 px at sigma ~0.1, 0.12 at 0.7 and 0.7 px at 1.5 (a glossy
# ball of radius 15 px on a plain wall) whatever the radius (10 or 15 px; at 5 px up to 0.8 px,
# which the small-ball term below holds). The sweep before the background left the ball out
# and the fit's starts reached below the coverage radius set it to 600 (sigma / r)^4 px (0.06 px
# at r = 15, sigma = 1.5; those plain-wall errors were up to 0.87 px there).
SYSTEMATIC_PX = 0.06
BLUR_PX3 = 0.09
# ... plus SMALL_BALL_PX5 / r^4 (px): a ball a few pixels across leaves the fit a few dozen rim
# pixels, where shading, blur and exposure trade against the radius (docs/tracking.md §3).
# On the paper's camera (r = 5 px, benchmarks/paper_camera.py, 32 clips) the radius comes out
# -6 to +10 % (up to 0.52 px); 200 px^5 (0.32 px at r = 5, 0.12 at 6.4, 0.02 at 10) gives
# those scales |z| <= 1.8. It was 375 when the fits' starts stayed above 0.8 of the coverage
# radius and frontally lit clips came out +13 to +18 % (fitted blur 0.16-0.53 px, true 0.6),
# and 2 px^2 / r^2 (0.08 px at r = 5) before that, which left |z| up to 6.7 there.
SMALL_BALL_PX5 = 200.0
# ... and, in quadrature, the blur's shape: the model's lens blur is a Gaussian; a lens out of
# focus blurs into a disk (a pillbox PSF), whose edge profile is not an error function, and
# where the blur is a large part of the radius the fit then trades it against the shading near
# the rim. On tests/render_pbr.py with a disk PSF (its SD 0.7-1.3 px; sharp, or softened by a
# 0.5 px Gaussian) and radius 10-20 px, the radius came out within 0.9 % up to a fitted blur of
# 7 % of the radius, then -6.8 to +9.0 % from 9 % on (z up to 3.7 with the terms above: the
# stated SD assumed the Gaussian; docs/tracking.md §3). So PSF_SHAPE_REL of the radius, ramped
# from a fitted blur of PSF_SHAPE_FROM of the radius to PSF_SHAPE_TO (those |z| <= 1.6; a
# Gaussian blur of 1.5 px at 10-15 px, errors <= 2.1 %, is then stated as 3.5-7.4 %)
PSF_SHAPE_REL = 0.06
PSF_SHAPE_FROM, PSF_SHAPE_TO = 0.07, 0.12
UNRELIABLE_BLUR = 0.15  # fitted sigma / r above which the radius is called unreliable
# fitted sigma / r up to which the edge fits' centres correct the centroids' bias and the
# small-ball fit (._refine) gives the centres: at 0.15 (as UNRELIABLE_BLUR until 2026-11-26) a
# side-lit 5 px ball blurred by 0.7 px with exposure 80 % fell just above it (fitted 0.150):
# centres 0.435 px RMS, 0.124 with the fit; radius 10 px, blur 1.5 px (fitted 0.155-0.158):
# side-lit 0.88 -> 0.21 and 0.89 -> 0.14 px, dark 0.105 -> 0.09 (benchmarks/tracking_accuracy.py).
# Above ~0.3 (5 px, blur 1.5 px) the fits hold a blur that trades against the shading and err more.
CENTRE_FIT_BLUR = 0.2
UNCERTAIN_RADIUS = 0.02  # relative SD of the radius above which a warning says to give a length


# RadiusFit.method
EDGE_MODEL, SMALL_BALL_FIT, JOINT_FIT = "edge model", "small-ball fit", "frames' joint fit"
# Systematic error of the small-ball fit's radius (._refine; a ball of radius <= 8 px with its
# blur <= SMALL_FIT_BLUR of it), px, in quadrature with its scatter across frames: over the 32
# clips of benchmarks/paper_camera.py and the 17 scenarios of benchmarks/tracking_accuracy.py
# where it runs (radius 5 px) its radius came out -6.8 to +4.0 % (RMS 1.7 %, 0.085 px; the
# edge model's -4.6 to +6.6 %, RMS 3.6 %), the largest a frontally lit MJPEG clip and one whose
# fitted blur is 0.48 px against 0.6; 0.13 px (2.6 % at 5 px) gives them |z| <= 2.6 (with the
# blur of 13 free fits, 2026-11-28: -6.4 to +2.6 %, RMS 1.4 %, |z| <= 2.32). Plus, in
# quadrature, the edge model's blur term BLUR_PX3 * sigma^3: under a 1.5 px blur (fitted
# 1.46-1.75 px) the radius came out -3.9 to +1.1 %, a glossy ball's -8 to -15 % (z <= 1.6)
SMALL_FIT_SYSTEMATIC_PX = 0.13
# ... and, in quadrature, SMALL_FIT_BLURRED_REL of the radius ramped from a fitted blur of
# SMALL_FIT_BLURRED_FROM of the radius (none) to SMALL_FIT_BLURRED_TO (full). The terms above
# were set on blurs of 0, 0.7 and 1.5 px; between them (2026-11-29: radius 5, 6.5 and 8 px,
# blur 0.7-1.5 px in six steps, exposure 0 and 80 %, two seeds, side-lit and glossy balls,
# tests/render_pbr.py) the radius came out within 2.4 % up to a fitted blur of 0.19 of it and
# -22 to +9 % beyond (a glossy 5 px ball blurred by 1-1.2 px: -7 to -22 %, z down to -3.4; its
# fitted blur 0.21-0.30 of the radius), where the shading near the rim and the blur trade
# against the radius even with the true blur held (-6 to -12 % at 1.2 px). With this term
# those scenes' |z| <= 1.9 (docs/tracking.md §3)
SMALL_FIT_BLURRED_REL = 0.10
SMALL_FIT_BLURRED_FROM, SMALL_FIT_BLURRED_TO = 0.17, 0.25
# fitted sigma / r up to which the small-ball fit (._refine) runs: at 5 px under a 1.5 px blur
# (fitted 0.29-0.35 of the true radius) its centres were 0.10-0.19 px against the centroids'
# 0.12-0.68 and its radius -3.9..+1.1 % (glossy -8.3) against -3.2..+2.1 % (glossy -14.0)
# (benchmarks/tracking_accuracy.py;
# without the shadow columns, before 2026-11-26, a glossy ball's centres went 0.65 -> 1.25 px).
# Two glossy balls there, whose edge radius is 17 % small (fitted blur 0.42 of it), stay with
# the edge model and its stated 28-30 %
SMALL_FIT_BLUR = 0.4
# A small ball (under SHADOW_MIN_RADIUS) blurred by more than WIDE_BLUR of its radius (below):
# MAX_FRAMES_BLURRED frames fitted together with the radius and the blur free
# (_small_blur_free). What tells the radius from the blur and the shading there is the wall's
# texture the ball hides: the Cramer-Rao bound of the radius (25 frames, tests/render_pbr.py,
# 5 px, blur 1.5 px; _joint_radius_sd) is 0.56-0.71 % on the textured wall of
# benchmarks/tracking_accuracy.py and 3.6-5.5 % on a plain one. So the joint radius is kept
# only where that bound with each frame's background made flat is JOINT_TEXTURE_GAIN times
# the bound or more (textured: 3.9 against 0.67 %; plain: 0.83 against 0.83 %, the fit +11 %
# off there), its SE the bound and JOINT_FIT_SYSTEMATIC_REL of the radius in quadrature
# (method JOINT_FIT): on benchmarks/tracking_small_blur.py's 43 rendered textured-wall scenes
# where it ran (radius 5 and 6.5 px, blur 1.0-1.5 px, side-lit, glossy and dark balls,
# exposure 0 and 50 %, two seeds) the radius came out -1.39 to +1.39 % (mean -0.19 %, RMS
# 0.61 %), on tracking_accuracy.py's six at 5 px -0.39 to +1.24 % (docs/tracking.md §3); a
# lens out of focus (a disk PSF, which the model's Gaussian is not) +2.1 and +3.4 % at 5 px
# under a 1.0 px blur: 2 % gives those |z| <= 1.66 and the Gaussian scenes <= 0.67 (1 %:
# 2.9 and 1.19)
JOINT_TEXTURE_GAIN = 2.0
JOINT_FIT_SYSTEMATIC_REL = 0.02
# ... from a free fits' blur of WIDE_BLUR of the radius (MORE_FRAMES_MAX_BLUR, 0.2, first):
# benchmarks/tracking_small_blur.py's 6.5 px balls under a 1.0-1.2 px blur (fitted 0.15-0.19
# of the radius) held by the small-ball fit came out -6.2 to +0.8 %, fitted so -0.4 to +0.6 %
# (its 66 joint fits -2.69 to +1.39 %, |z| <= 1.30); where the joint fit is not kept there,
# the radius alone with the blur held, as below MORE_FRAMES_MAX_BLUR (_joint_alike)
WIDE_BLUR = 0.15
# Strong JPEG compression (MJPEG, JPEG frames; the quality read by ._video.jpeg_quality): the
# codec quantises each 8 x 8 block, which rings at the ball's edge. Rendered balls
# (tests/render_pbr.py, side-lit, glossy and dark, blur 0 and 0.7 px, seeds 8 and 3), each
# frame a JPEG of quality 70..30: radius 5 px off by up to 7.7 % at quality 70 and 9.8-14 % at
# 60..30, 10 px by up to 3.4 % and 6.3-7.9 %, 15 px by at most 1.3 % (|z| up to 5.9 with the
# terms above: docs/tracking.md §3). So COMPRESSION_PX (px) in quadrature with either
# method's systematic error, ramped linearly from a quality of COMPRESSION_FROM (none) to
# COMPRESSION_FULL (full): those scenes |z| <= 2.44 (RMS 0.77; per quality and radius up to 1.3;
# generous at 15 px); 2.67 (RMS 0.76) since the wall's occlusion term (2026-11-28). OpenCV's
# MJPEG writer codes at ~80-90: untouched.
COMPRESSION_PX = 0.3
COMPRESSION_FROM, COMPRESSION_FULL = 80.0, 60.0
# Other lossy codecs (MPEG-4 part 2, H.264, ...), whose quantiser is not read: the file's size
# per pixel of its frames stands for it. Rendered balls (tests/render_pbr.py: radius 5/10/15 px,
# blur 0 and 0.7 px, exposure 40 %, three lightings, seeds 8 and 3; FFmpeg's mpeg4 at qscale
# 2-31 and libx264 at CRF 18-42, decoded by OpenCV; benchmarks/tracking_codecs.py): at 0.3
# bits per pixel or more every radius within 0.15 px; below it off by up to 0.55 px (0.1-0.3),
# 0.76 (0.05-0.1), 1.1 (0.04-0.05) and 3.7 px (below 0.04; H.264 at CRF 18, its
# "visually lossless", 0.04-0.11 bits per pixel here: 10 px balls up to 5.9 % off, |z| 5.2
# without this). So CODEC_PX (px) at CODEC_BITS bits per pixel, linear in log(bits) between
# and flat beyond, in quadrature like the JPEG term: those 324 scenes |z| <= 2.58 (RMS 0.59;
# 4.08 with 1.5 px at the lowest rates, where a 5 px ball came out up to 68 % off), a third
# seed not used to choose it |z| <= 2.62 (RMS 0.70)
CODEC_BITS = (0.03, 0.05, 0.1, 0.3)
CODEC_PX = (2.5, 0.4, 0.3, 0.0)


def spread(n: int, k: int) -> np.ndarray:
    """Up to ``k`` of ``range(n)``, evenly spaced (int64)."""
    return np.unique(np.linspace(0, n - 1, min(k, n)).round()).astype(np.int64)


def median_and_se(values: np.ndarray) -> tuple[float, float]:
    """The median of ``values`` and its standard error: 1.2533 sd / sqrt(n), the sd from the
    MAD (robust)."""
    med = float(np.median(values))
    return med, 1.2533 * 1.4826 * float(np.median(np.abs(values - med))) / math.sqrt(len(values))


def _ramp(x: float, zero_at: float, full_at: float) -> float:
    """0 at ``zero_at``, 1 at ``full_at``, linear between and flat beyond (either order)."""
    return min(max((x - zero_at) / (full_at - zero_at), 0.0), 1.0)


def psf_shape_px(radius_px: float, blur_px: float | None) -> float:
    """The edge model's radius error (px) that the lens blur's unknown shape allows:
    ``PSF_SHAPE_REL`` of the radius, ramped linearly from a fitted blur of ``PSF_SHAPE_FROM``
    of the radius (zero) to ``PSF_SHAPE_TO`` (full)."""
    blur = 0.0 if blur_px is None else blur_px
    return PSF_SHAPE_REL * radius_px * _ramp(blur / radius_px, PSF_SHAPE_FROM, PSF_SHAPE_TO)


def compression_px(jpeg_quality: float | None, bits_per_pixel: float | None = None) -> float:
    """The radius error (px) that compression of the frames allows: for JPEG-coded frames of
    quality ``jpeg_quality``, ``COMPRESSION_PX`` ramped from a quality of ``COMPRESSION_FROM``
    (zero) to ``COMPRESSION_FULL`` (full); for other video, by the file's ``bits_per_pixel``
    (``CODEC_PX`` at ``CODEC_BITS``, linear in its logarithm); zero where neither is known."""
    if jpeg_quality is not None and math.isfinite(jpeg_quality):
        return COMPRESSION_PX * _ramp(jpeg_quality, COMPRESSION_FROM, COMPRESSION_FULL)
    if bits_per_pixel is None or not bits_per_pixel > 0.0 or not math.isfinite(bits_per_pixel):
        return 0.0
    return float(np.interp(math.log(bits_per_pixel), np.log(CODEC_BITS), CODEC_PX))


def small_fit_blurred_px(radius_px: float, blur_px: float) -> float:
    """The small-ball fit's radius error (px) where its blur is a large part of the radius:
    ``SMALL_FIT_BLURRED_REL`` of the radius, ramped linearly from a fitted blur of
    ``SMALL_FIT_BLURRED_FROM`` of the radius (zero) to ``SMALL_FIT_BLURRED_TO`` (full)."""
    return SMALL_FIT_BLURRED_REL * radius_px * _ramp(
        blur_px / radius_px, SMALL_FIT_BLURRED_FROM, SMALL_FIT_BLURRED_TO)


def edge_model_systematic_px(radius_px: float, blur_px: float | None) -> float:
    """The edge model's systematic radius error (px) for a fitted blur ``blur_px``: the sum
    of ``SYSTEMATIC_PX``, the blur term ``BLUR_PX3 blur^3`` and the small-ball term
    ``SMALL_BALL_PX5 / r^4``, in quadrature with the blur's shape (:func:`psf_shape_px`)."""
    blur = 0.0 if blur_px is None else blur_px
    return math.hypot(SYSTEMATIC_PX + BLUR_PX3 * blur**3 + SMALL_BALL_PX5 / radius_px**4,
                      psf_shape_px(radius_px, blur_px))


# the fraction of the frames fitted whose wall beside the ball is not the background's on
# some side (RadiusFit.foreign) from which the ball's radius gets a warning, and its relative
# SD FOREIGN_REL_SD more in quadrature: the sides left out, the rest of the rim still reads a
# shadow's penumbra. Rendered bright balls of 10, 12 and 15 px with a lamp's shadow of the
# ball on the wall (tests/render_pbr.py's cast: four offsets and depths each; 2026-11-28,
# eighth session): scale errors -0.35 to +2.92 %, RMS 1.4 %, against stated SDs of 0.6-1.1 %
# (z up to 2.9); with this term z up to 1.6
FOREIGN_WARNING = 0.5
FOREIGN_REL_SD = 0.015


# The exposure's smear is held as a Gaussian along the ball's motion (the module's docstring):
# a box of the smear's length, which a Gaussian of its variance stands for while the smear is
# short beside the radius. A phone's slow motion smears the ball further
# (benchmarks/tracking_phone.py: a 10 px ball at 120-480 fps, exposures of 25-90 %): the
# radius within -1.4..+0.6 % up to 0.75 radii of smear; by hand at 120 fps, 60-80 % (0.9-1.2
# radii) -0.8..+4.2 %, and a clip whose ball came in at 17.5 px a frame, exposure 50 % (0.88
# radii; 0.70 as fitted) +5.4 % at a stated 1.1 %; at 1.3 radii (120 fps, 90 %; 1.1 as
# fitted) 11-12 % too large, at stated SDs of 2.7-3.8 %. So the radius's relative SD takes
# SMEAR_SQ times the square of the smear in radii (the fitted exposure times the ball's
# median step, over the radius: smear_radii) in quadrature (the box and the Gaussian differ
# from their fourth moments on), and from SMEAR_RADII of smear it is said and at least
# SMEAR_REL_SD
SMEAR_SQ = 0.045
SMEAR_RADII = 1.0
SMEAR_REL_SD = 0.12


def smear_radii(fit: RadiusFit | None, centre: np.ndarray) -> float:
    """The exposure's smear of the ball over its radius: ``fit``'s exposure (a fraction of
    the frame interval) times the median step between the found ``centre``s of consecutive
    frames (px), over ``fit``'s radius; 0 without a fit or two consecutive frames."""
    if fit is None or not math.isfinite(fit.exposure):
        return 0.0
    steps = np.hypot(*np.diff(np.asarray(centre, dtype=float), axis=0).T)
    steps = steps[np.isfinite(steps)]
    return float(fit.exposure * np.median(steps) / fit.radius) if steps.size else 0.0


def smear_share(smear: float) -> float:
    """The radius's relative SD on account of the exposure's ``smear`` (radii): ``SMEAR_SQ``
    times its square, and at least ``SMEAR_REL_SD`` from ``SMEAR_RADII`` on."""
    return max(SMEAR_SQ * smear * smear, SMEAR_REL_SD if smear >= SMEAR_RADII else 0.0)


DEPTH_WARNING = 0.01  # the ball's picture larger or smaller by this fraction over the frames
DEPTH_SD = 5.0        # fitted, and by this many SEs: it moves along the camera's axis (told)
DEPTH_MIN_FRAMES = 5  # single-frame radii at least (a straight line through them)


def depth_change(frames: Sequence[int], radii: Sequence[float]) -> tuple[float, float] | None:
    """How much larger the ball's picture is at the last of ``frames`` than at the first (a
    fraction), from a straight line through the frames' own radii (least squares; a pinhole
    camera sees a ball coming closer at a steady speed grow as one over its distance, which
    over a few per cent is a straight line), and its SE (from the radii's scatter about the
    line); None with under ``DEPTH_MIN_FRAMES`` radii. A still ball on 52 rendered clips
    (radius 5-15 px, 9 or 25 radii): never beyond 2.9 SEs (SEs 0.02-4.9 %)."""
    k, r = np.asarray(frames, dtype=float), np.asarray(radii, dtype=float)
    if len(r) < DEPTH_MIN_FRAMES or len(r) != len(k) or np.ptp(k) == 0:
        return None
    dk = k - k.mean()
    slope = float(dk @ (r - r.mean()) / (dk @ dk))
    resid = r - r.mean() - slope * dk
    se = math.sqrt(float(resid @ resid) / (len(r) - 2) / float(dk @ dk))
    span = float(np.ptp(k)) / float(r.mean())
    return slope * span, se * span


def depth_told(fit: RadiusFit | None) -> float:
    """The change of :func:`depth_change` where it is ``DEPTH_WARNING`` or more and
    ``DEPTH_SD`` SEs (the ball moves along the camera's axis), else 0."""
    change = None if fit is None else depth_change(fit.frames, fit.radii)
    return change[0] if change is not None and depth_is_told(change) else 0.0


def depth_is_told(change: tuple[float, float] | None) -> bool:
    """Whether :func:`depth_change`'s ``(change, SE)`` is ``DEPTH_WARNING`` or more and
    ``DEPTH_SD`` SEs."""
    return change is not None and abs(change[0]) >= max(DEPTH_WARNING, DEPTH_SD * change[1])


def radius_relative_sd(radius_px: float, radius_se_px: float, blur_px: float | None,
                       method: str = EDGE_MODEL, jpeg_quality: float | None = None,
                       bits_per_pixel: float | None = None, foreign: float = 0.0,
                       depth: float = 0.0, smear: float = 0.0) -> float:
    """The relative standard deviation of the ball's radius: its scatter across frames
    ``radius_se_px`` and the systematic error in quadrature: the edge model's
    (:func:`edge_model_systematic_px`), or ``SMALL_FIT_SYSTEMATIC_PX`` and the blur term
    ``BLUR_PX3 * blur_px^3`` and :func:`small_fit_blurred_px` in quadrature where ``method``
    is ``SMALL_BALL_FIT``, or ``JOINT_FIT_SYSTEMATIC_REL`` of the radius where it is
    ``JOINT_FIT``; the
    frames' compression (:func:`compression_px`: their JPEG quality, or the video's bits per
    pixel); ``FOREIGN_REL_SD`` where ``foreign`` (the fraction of the frames fitted with
    sides of the rim left out, ``RadiusFit.foreign``) is ``FOREIGN_WARNING`` or more; and half
    of ``depth``, the ball's picture's change over the frames (:func:`depth_told`: the median
    radius is the ball's at one distance only); ``SMEAR_SQ`` times the square of the
    exposure's ``smear`` in radii (:func:`smear_radii`), and at least ``SMEAR_REL_SD`` where
    that is ``SMEAR_RADII`` or more."""
    blur = 0.0 if blur_px is None else blur_px
    if method == SMALL_BALL_FIT:
        systematic = math.hypot(SMALL_FIT_SYSTEMATIC_PX, BLUR_PX3 * blur**3,
                                small_fit_blurred_px(radius_px, blur))
    elif method == JOINT_FIT:
        systematic = JOINT_FIT_SYSTEMATIC_REL * radius_px
    else:
        systematic = edge_model_systematic_px(radius_px, blur_px)
    compression = compression_px(jpeg_quality, bits_per_pixel)
    shadow = FOREIGN_REL_SD if foreign >= FOREIGN_WARNING else 0.0
    rel = math.hypot(math.hypot(radius_se_px, systematic, compression) / radius_px, shadow,
                     0.5 * depth, SMEAR_SQ * smear * smear)
    return max(rel, smear_share(smear))


class RadiusFit(NamedTuple):
    """The ball's radius from the edge model (or, for a small ball, the small-ball fit:
    ``method``): ``radius`` (px) and its standard error
    ``radius_se`` (px, from the scatter of single-frame radii with the shared blur and
    shading held), blur ``sigma`` (px), ``exposure`` (fraction of the frame interval), RMS
    residual (grey levels), and the frames fitted; ``centre_sd``: the tracked centres' per-frame
    standard deviation (px, per coordinate), set by :func:`._quality.fit_ball_radius`;
    ``light``: the direction of the light whose shadow the model holds (azimuth in the image
    from +u towards +v, elevation towards the camera; radians, pi/2: lit from the camera)."""

    radius: float
    radius_se: float
    sigma: float
    exposure: float
    rms: float
    frames: tuple[int, ...]
    centres: np.ndarray    # the edge fits' centres of ``frames`` (px)
    centre_sd: float = math.nan  # per-frame SD of the tracked centres, per coordinate (px)
    light: tuple[float, float] = (math.nan, math.nan)  # the light's azimuth, elevation (rad)
    method: str = EDGE_MODEL  # what gave ``radius``: EDGE_MODEL or SMALL_BALL_FIT (._refine)
    # the fraction of the frames fitted where the wall beside the ball is not the background
    # model's in some of its sectors (left out of the fits: foreign_fraction)
    foreign: float = 0.0
    radii: tuple[float, ...] = ()  # each of ``frames``' own radius, the blur and light held
    cast: CastShadow | None = None  # the ball's shadow on the wall where it hugs the edge


def foreign_fraction(frames: Sequence[np.ndarray], backgrounds: Sequence[np.ndarray],
                     centres: np.ndarray, r: float, sigma: float) -> float:
    """The fraction of ``frames`` (each with its ``backgrounds`` scaled to it, the ball at
    ``centres``, radius ``r`` and blur ``sigma``, px) where some polar sectors of the wall just
    beyond the ball's blurred rim are not the background's
    (:func:`._edge_kernel.foreign_sectors`, on the pixels the fits read there)."""
    from ._edge_kernel import BAND_BLURS, BAND_PX, foreign_sectors

    band_from = r + BAND_BLURS * math.sqrt(sigma * sigma + 1.0 / 12.0)
    reach = band_from + BAND_PX
    hit = 0
    for img, bg, c in zip(frames, backgrounds, centres, strict=True):
        if (window := _window(c, reach, img.shape)) is None:
            continue
        u0, v0, u1, v1 = window
        vv, uu = np.mgrid[v0:v1, u0:u1].astype(np.float64)
        du, dv = (uu - c[0]).ravel(), (vv - c[1]).ravel()
        rho = np.hypot(du, dv)
        ring = (rho > r) & (rho <= reach)
        res = (img[v0:v1, u0:u1].astype(np.float64) - bg[v0:v1, u0:u1]).ravel()
        hit += bool(foreign_sectors(res[ring], du[ring], dv[ring], rho[ring], band_from).any())
    return hit / max(len(frames), 1)


def _window(c, reach: float, shape: tuple[int, ...]) -> tuple[int, int, int, int] | None:
    """The columns and rows ``u0, v0, u1, v1`` (ends exclusive) of the pixels within ``reach``
    of ``c``; None where they leave a frame of ``shape``."""
    u0, v0 = int(math.floor(c[0] - reach)), int(math.floor(c[1] - reach))
    u1, v1 = int(math.ceil(c[0] + reach)) + 1, int(math.ceil(c[1] + reach)) + 1
    if u0 < 0 or v0 < 0 or u1 > shape[1] or v1 > shape[0]:
        return None
    return u0, v0, u1, v1


class _Pixels(NamedTuple):
    u: np.ndarray          # pixel column
    v: np.ndarray          # pixel row
    grey: np.ndarray       # grey level
    bg: np.ndarray         # background model, scaled to the frame
    gbu: np.ndarray        # its gradient (grey levels per px: the wall's occlusion term)
    gbv: np.ndarray
    cx: np.ndarray         # the ball's centre in the pixel's frame
    cy: np.ndarray
    dir_u: np.ndarray      # direction of motion in the pixel's frame
    dir_v: np.ndarray
    speed: np.ndarray      # px per frame
    frame: np.ndarray      # 0 .. n_frames - 1
    n_frames: int
    weight: np.ndarray
    kappa: np.ndarray      # the background's variance over the frame's noise variance


# the fields of _Pixels with one entry per pixel (all but n_frames)
_PER_PIXEL = tuple(name for name in _Pixels._fields if name != "n_frames")


@functools.lru_cache(maxsize=1)
def _sqrt_table() -> tuple[np.ndarray, np.ndarray]:
    """``G(z) = E[sqrt(z + Z)_+]``, ``Z ~ N(0, 1)``, on a grid of z: the Gaussian moment of a
    fractional power, ``E[(z + Z)_+^nu] = Gamma(nu + 1) phi(z) e^(z^2 / 4) D_(-nu-1)(-z)``
    (``D`` the parabolic cylinder function; from its integral representation, DLMF 12.5.1;
    checked against direct quadrature to 1e-6)."""
    from scipy.special import pbdv

    z = np.linspace(-8.0, 30.0, 3801)
    d, _ = pbdv(-1.5, -z)
    g = math.gamma(1.5) / math.sqrt(2 * math.pi) * np.exp(-z * z / 4) * d
    return z, g


@functools.lru_cache(maxsize=1)
def _bessel_table() -> tuple[np.ndarray, float]:
    """``I_m(a) exp(-a)`` for ``m = 0 .. RIM_ORDER`` on ``a = 0, 0.005, .., 40`` (SciPy's
    ``ive``), and the spacing: the exact columns' kernels (:func:`._edge_kernel._hankel`;
    linearly interpolated to within 3e-6, the large-argument series beyond)."""
    from scipy.special import ive

    da = 0.005
    a = np.arange(8001) * da
    return np.stack([ive(m, a) for m in range(RIM_ORDER + 1)]), da


def _ive_numpy(a: np.ndarray) -> np.ndarray:
    """``I_m(a) exp(-a)`` ``(RIM_ORDER + 1, n)`` as :func:`._edge_kernel._ive` computes it."""
    etab, da = _bessel_table()
    x = a / da
    inside = x < etab.shape[1] - 1
    j = np.minimum(x, etab.shape[1] - 2).astype(np.intp)
    f = x - j
    table = etab[:, j] * (1.0 - f) + etab[:, j + 1] * f
    big = np.maximum(a, 1.0)
    inv = 1.0 / (8.0 * big)
    series = [(1.0 + inv * (1.0 + inv * (4.5 + inv * (37.5 + inv * 459.375)))),
              (1.0 - inv * (3.0 + inv * (7.5 + inv * (52.5 + inv * 590.625))))]
    series = [t / np.sqrt(2 * math.pi * big) for t in series]
    for m in range(1, RIM_ORDER):
        series.append(series[m - 1] - 2.0 * m / big * series[m])
    return np.where(inside, table, np.array(series))


@functools.lru_cache(maxsize=1)
def _hankel_nodes() -> np.ndarray:
    """The exact columns' quadrature nodes (:func:`._edge_kernel.hankel_nodes`)."""
    from ._edge_kernel import hankel_nodes

    return hankel_nodes()


def _hankel_numpy(rho: np.ndarray, s: np.ndarray, r: float) -> np.ndarray:
    """The exact columns' radial factors ``(n, 6 + RIM_ORDER - 1)`` at ``rho`` (blur ``s``):
    :func:`._edge_kernel._hankel`'s values in NumPy."""
    from ._edge_kernel import _HANKEL_CUT, _HANKEL_SPLIT, _NODES_IN, _PROFILE_M

    nodes = _hankel_nodes()
    lo = np.maximum(rho - _HANKEL_CUT * s, 0.0)
    hi = np.minimum(rho + _HANKEL_CUT * s, r)
    live = hi > lo
    mid = np.where(hi < r, hi, np.maximum(lo, r - _HANKEL_SPLIT * s))
    half_in = 0.5 * (mid - lo)[:, None]
    rp_in = lo[:, None] + half_in * (1.0 + nodes[0, :_NODES_IN])
    jw_in = np.where(mid > lo, 1.0, 0.0)[:, None] * half_in * nodes[1, :_NODES_IN]
    half_rim = 0.5 * np.sqrt(np.maximum(r - mid, 0.0))[:, None]
    w = half_rim * (1.0 + nodes[0, _NODES_IN:])
    rim = ((hi >= r) & (mid < r))[:, None]
    rp_rim = r - w * w
    jw_rim = np.where(rim, 2.0 * w * half_rim * nodes[1, _NODES_IN:], 0.0)
    rp, jw = np.hstack([rp_in, rp_rim]), np.hstack([jw_in, jw_rim])
    s2 = (s * s)[:, None]
    kern = rp / s2 * np.exp(-0.5 * (rho[:, None] - rp) ** 2 / s2) * jw
    ev = _ive_numpy((rho[:, None] * rp / s2).ravel()).reshape(-1, *rp.shape)
    x = rp / r
    root = np.sqrt(np.clip(1.0 - x * x, 0.0, None))
    profiles = [np.ones_like(x), x, root, x * x, x * root, 1.0 - x * x]
    orders = list(_PROFILE_M) + list(range(2, RIM_ORDER + 1))
    profiles += [np.ones_like(x)] * (RIM_ORDER - 1)
    cols = [(kern * ev[m] * g).sum(1) for m, g in zip(orders, profiles, strict=True)]
    return np.where(live[:, None], np.column_stack(cols), 0.0)


@functools.lru_cache(maxsize=2)
def _nodes(n: int = SHADOW_NODES) -> np.ndarray:
    """Gauss-Legendre nodes and weights on [-1, 1], ``(2, n)``: the shadow columns'
    quadrature (:func:`._edge_kernel._shadow`)."""
    return np.stack(np.polynomial.legendre.leggauss(n))


def _shadow_numpy(uu, s, r, ct, st, az: float, el: float, n: int) -> np.ndarray:
    """The shadow columns ``(n_pix, 2)`` of :func:`._edge_kernel._shadow`, in NumPy, with
    ``n`` quadrature nodes."""
    from ._edge_kernel import _CUT

    x, w = _nodes(n)
    a = math.cos(el) * (ct * math.cos(az) + st * math.sin(az))
    lz = math.sin(el)
    with np.errstate(divide="ignore", invalid="ignore"):
        w_star = r * (1.0 - lz / np.sqrt(a * a + lz * lz))
    lo = np.maximum(0.0, uu - _CUT * s)
    hi = np.minimum(w_star, uu + _CUT * s)
    live = (a < 0.0) & (hi > lo)
    t0, t1 = np.sqrt(lo), np.sqrt(np.maximum(hi, lo))
    tau = 0.5 * (t0 + t1)[:, None] + 0.5 * (t1 - t0)[:, None] * x
    depth = tau * tau
    jac = tau * (t1 - t0)[:, None] * w
    g = jac * np.exp(-0.5 * ((depth - uu[:, None]) / s[:, None]) ** 2) / (
        math.sqrt(2 * math.pi) * s[:, None])
    nzw = tau * np.sqrt(np.maximum(2 * r - depth, 0.0)) / r
    m = a[:, None] * (1.0 - depth / r) + lz * nzw
    cols = np.stack([(g * m).sum(1), (g * m * nzw).sum(1)], axis=1)
    return np.where(live[:, None], cols, 0.0)


def _radial_numpy(u: np.ndarray, s: np.ndarray, r: float) -> tuple[np.ndarray, ...]:
    """The radial factors blurred along the radius (:func:`._edge_kernel._analytic`) at depth
    ``u`` and blur ``s``: ``step, qq, nz, q2, nzq`` and ``n_z^2 = step - q2``."""
    from scipy.special import ndtr

    z = u / s
    dens = np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
    step = ndtr(z)
    ramp = u * step + s * dens                      # E[(u + e) 1{u + e > 0}]
    square = (u * u + s * s) * step + u * s * dens  # E[(u + e)^2 1{.}]
    zt, gt = _sqrt_table()
    root = np.sqrt(s) * np.interp(z, zt, gt, right=np.nan)
    root = np.where(np.isnan(root), np.sqrt(np.maximum(u, 0.0)), root)
    # blurred n_z = sqrt(u (2r - u)) / r, and q = rho / r, q^2 (n_x = q cos t, ...)
    nz = root * math.sqrt(2.0 / r) * np.sqrt(np.clip(1.0 - u / (2.0 * r), 0.0, 1.0))
    qq = step - ramp / r
    q2 = step - 2.0 * ramp / r + square / (r * r)
    return step, qq, nz, q2, nz * np.clip(1.0 - u / r, 0.0, 1.0), step - q2


def _design_numpy(q: np.ndarray, px: _Pixels, exact: bool = False
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Design matrix ``(n_pix, n_cols)`` at ``q = (r, sigma, exposure, az, el)``, and the
    model's fixed part, ``bg (1 - step)`` and the wall's occlusion term: the NumPy reference
    of the compiled :func:`._edge_kernel.varpro` (the tests compare them); ``exact``: its
    radial factors blurred in two dimensions (:func:`._edge_kernel._hankel`)."""
    r, sigma, exposure, az, el = q
    du, dv = px.u - px.cx, px.v - px.cy
    rho = np.hypot(du, dv)
    ct, st = du / np.maximum(rho, 1e-9), dv / np.maximum(rho, 1e-9)
    cos_v = ct * px.dir_u + st * px.dir_v           # cos(t - t_v)
    smear2 = (exposure * px.speed) ** 2 / 12.0
    base = sigma * sigma + 1.0 / 12.0
    var_r = base + smear2 * cos_v * cos_v
    var_t = base + smear2 * (1.0 - cos_v * cos_v)
    s = np.sqrt(var_r)
    u = r - var_t / (2.0 * r) - rho
    z = u / s
    dens = np.exp(-0.5 * z * z) / math.sqrt(2 * math.pi)
    if exact:
        h = _hankel_numpy(r - u - var_r / (2.0 * r), s, r)
        step, qq, nz, q2, nzq, nz2 = h[:, :6].T
        rims = list(h[:, 6:].T)
    else:
        step, qq, nz, q2, nzq, nz2 = _radial_numpy(u, s, r)
        rims = [step] * (RIM_ORDER - 1)
    c2, s2 = ct * ct - st * st, 2.0 * ct * st
    cols = [step, qq * ct, qq * st, nz, q2 * s2, q2 * c2, nzq * ct, nzq * st, nz2,
            rims[0] * c2, rims[0] * s2]
    cm, sm = c2, s2
    for m in range(3, RIM_ORDER + 1):
        cm, sm = cm * ct - sm * st, sm * ct + cm * st
        cols += [rims[m - 2] * cm, rims[m - 2] * sm]
    if el < 0.5 * math.pi:  # else lit from the camera: no shadow, no columns
        cols += list(_shadow_numpy(u, s, r, ct, st, az, el, SHADOW_NODES).T)
    shared = np.column_stack(cols)
    out = 1.0 - step
    local = np.zeros((rho.size, 3 * px.n_frames))
    rows = np.arange(rho.size)
    for j, a in enumerate((out, out * ct, out * st)):
        local[rows, 3 * px.frame + j] = a
    occ = (sigma * sigma + 1.0 / 12.0) * (px.gbu * ct + px.gbv * st) * dens / s
    return np.hstack([shared, local]), px.bg * (1.0 - step) + occ


def _residual(q: np.ndarray, px: _Pixels, exact: bool = False) -> np.ndarray:
    """Weighted residuals at ``q = (cx, cy, r, sigma, exposure, az, el)`` (one frame) or
    ``(r, sigma, exposure, az, el)`` (the centres held), the linear coefficients solved;
    ``exact``: the columns blurred in two dimensions (:func:`._edge_kernel._hankel`)."""
    return _evaluate(q, px, _NONE_FREE, False, exact)[0]


_NONE_FREE = np.zeros(7, bool)


def _evaluate(q: np.ndarray, px: _Pixels, free: np.ndarray, want_jac: bool,
              exact: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Weighted residuals at ``q`` (as :func:`_residual`) and, with ``want_jac``, their
    Jacobian with respect to the entries of ``(cx, cy, r, sigma, exposure, az, el)`` flagged
    in ``free`` (analytic, :func:`._edge_kernel.varpro`: one compiled call). Raises
    ``np.linalg.LinAlgError`` where the linear coefficients are not determined."""
    from ._edge_kernel import varpro

    if q.size == 7:
        cx, cy = float(q[0]), float(q[1])
        cu = cv = np.zeros(px.u.size)
        q = q[2:]
    else:
        cx = cy = 0.0
        cu, cv = px.cx, px.cy
    zt, gt = _sqrt_table()
    r, sigma, exposure, az, el = (float(x) for x in q)
    res, jac, ok = varpro(cx, cy, r, sigma, exposure, az, el, free, px.u, px.v, cu, cv,
                          px.dir_u, px.dir_v, px.speed, px.frame, px.n_frames, px.weight,
                          px.kappa, px.grey, px.bg, px.gbu, px.gbv, float(zt[0]),
                          float(zt[1] - zt[0]), gt, _nodes(), RIM_ORDER, want_jac, exact,
                          _hankel_nodes(), *_bessel_table())
    if not ok:
        raise np.linalg.LinAlgError("edge model: singular normal equations")
    return res, jac


SATURATED = 254.5  # grey levels: a pixel at or above is saturated


def _grow(mask: np.ndarray, steps: int) -> np.ndarray:
    """``mask`` grown by ``steps`` px along rows and columns (a diamond; SciPy's binary
    dilation with its 4-connected cross)."""
    from scipy.ndimage import binary_dilation

    return binary_dilation(mask, iterations=steps) if steps >= 1 else mask.copy()


def _near_saturated(img: np.ndarray, px: _Pixels, steps: int) -> np.ndarray:
    """Whether each pixel of ``px`` (one frame's, of ``img``) is within ``steps`` px (along
    rows and columns) of a saturated one."""
    u, v = px.u.astype(np.intp), px.v.astype(np.intp)
    u0, v0 = max(u.min() - steps, 0), max(v.min() - steps, 0)
    box = img[v0:v.max() + steps + 1, u0:u.max() + steps + 1] >= SATURATED
    if not box.any():
        return np.zeros(u.size, bool)
    return _grow(box, steps)[v - v0, u - u0]


def _pixels(img, bg, c, vel, r0: float, inner: float, outer: float, occlusion: bool,
            kappa: np.ndarray | None) -> _Pixels | None:
    """Pixels of one frame with ``r0 - inner <= rho <= r0 + outer`` from ``c``, saturated ones
    and their neighbours left out, and the polar sectors whose wall beyond the rim (the
    outermost ``BAND_PX``) is not the background's (:func:`._edge_kernel.foreign_sectors`),
    with the background's gradient where ``occlusion`` (else
    zero: no occlusion term) and its relative variance ``kappa`` (a map as the frame's; None:
    the background taken as exact); None if they leave the frame."""
    h, w = img.shape
    reach = r0 + outer
    if (window := _window(c, reach, img.shape)) is None:
        return None
    u0, v0, u1, v1 = window
    sub = img[v0:v1, u0:u1].astype(np.float64)
    vv, uu = np.mgrid[v0:v1, u0:u1].astype(np.float64)
    rho = np.hypot(uu - c[0], vv - c[1])
    near = (rho >= r0 - inner) & (rho <= reach)
    sat = sub >= SATURATED
    if sat.any():
        near &= ~_grow(sat, 1)
    idx = np.flatnonzero(near)
    # the wall beside the ball as the background model has it (a lamp's shadow of the ball)
    from ._edge_kernel import BAND_PX, foreign_sectors

    res0 = sub.ravel()[idx] - bg[v0:v1, u0:u1].ravel()[idx]
    idx = idx[~foreign_sectors(res0.astype(np.float64), uu.ravel()[idx] - c[0],
                               vv.ravel()[idx] - c[1], rho.ravel()[idx], reach - BAND_PX)]
    if idx.size > MAX_PIXELS:  # a large ball: every k-th pixel (raster order) holds the edge
        idx = idx[::-(-idx.size // MAX_PIXELS)]
    n = idx.size
    uu, vv, sub = uu.ravel()[idx], vv.ravel()[idx], sub.ravel()[idx]
    bgw = bg[v0:v1, u0:u1].ravel()[idx].astype(np.float64)
    # the background's gradient (central differences; one-sided at the frame's border), for
    # the wall's occlusion term
    if occlusion:
        pu0, pv0 = max(u0 - 1, 0), max(v0 - 1, 0)
        win = bg[pv0:min(v1 + 1, h), pu0:min(u1 + 1, w)].astype(np.float64)
        g_v, g_u = np.gradient(win)
        box = (slice(v0 - pv0, v1 - pv0), slice(u0 - pu0, u1 - pu0))
        gbu, gbv = g_u[box].ravel()[idx], g_v[box].ravel()[idx]
    else:
        gbu = gbv = np.zeros(idx.size)
    kap = np.zeros(n) if kappa is None else \
        kappa[v0:v1, u0:u1].ravel()[idx].astype(np.float64)
    speed = math.hypot(*vel)
    du, dv = (vel[0] / speed, vel[1] / speed) if speed > 0 else (1.0, 0.0)
    full = functools.partial(np.full, n)
    return _Pixels(uu, vv, sub, bgw, gbu, gbv, full(c[0]), full(c[1]), full(du), full(dv),
                   full(speed), np.zeros(n, np.intp), 1, np.ones(n), kap)


class EdgeFit(NamedTuple):
    """One frame's fit: centre and radius (px), blur sigma (px), exposure, RMS residual, and
    the light's direction (azimuth in the image, from +u towards +v, and elevation towards the
    camera; radians)."""

    cx: float
    cy: float
    r: float
    sigma: float
    exposure: float
    rms: float
    az: float
    el: float
    drop: np.ndarray | None = None  # the rim's polar sectors left out (a logo), if any


def _rim_pixels(img, bg, q: np.ndarray, velocity, kappa: np.ndarray | None,
                occlusion: bool | None = None) -> _Pixels | None:
    """The pixels the fit at ``q = (cx, cy, r, sigma, exposure, ...)`` reads: from 2.5 blurs
    (or ``INNER r``) inside the rim to 2 px + 3 blurs outside (:func:`_pixels`), with the
    wall's occlusion term where ``occlusion`` (None: for a ball of ``OCCLUSION_MIN_RADIUS``
    or more)."""
    b = _blur(q, velocity)
    occlusion = q[2] >= OCCLUSION_MIN_RADIUS if occlusion is None else occlusion
    return _pixels(img, bg, q[:2], velocity, q[2], max(2.5 * b, INNER * q[2]), 2.0 + 3.0 * b,
                   occlusion, kappa)


def _blur(q: np.ndarray, velocity) -> float:
    """The largest SD of the step at ``q = (cx, cy, r, sigma, exposure, ...)`` (px): the
    lens, the pixel and the exposure's smear along the ball's motion."""
    return math.sqrt(q[3] ** 2 + 1 / 12 + (q[4] * math.hypot(*velocity)) ** 2 / 12)


def _solve(px: _Pixels, q: np.ndarray, free: np.ndarray, lo: np.ndarray, hi: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """The compiled fit (:func:`._edge_kernel.fit_frame`) of the parameters ``free`` of ``q``
    within ``lo, hi`` to the pixels ``px``: the parameters and residuals."""
    from ._edge_kernel import fit_frame

    zt, gt = _sqrt_table()
    q, res, status = fit_frame(q, free, lo[free], hi[free], 0.05, XTOL, FTOL, MAX_NFEV, px.u,
                               px.v, px.dir_u, px.dir_v, px.speed, px.frame, px.n_frames,
                               px.weight, px.kappa, px.grey, px.bg, px.gbu, px.gbv, float(zt[0]),
                               float(zt[1] - zt[0]), gt, _nodes(), RIM_ORDER, False,
                               _hankel_nodes(), *_bessel_table())
    if status < 0:
        raise np.linalg.LinAlgError("edge model: singular normal equations")
    return q, res


def fit_edge(img: np.ndarray, bg: np.ndarray, centre, velocity, r0: float, *,
             held: tuple[float, float, float, float] | None = None,
             light: tuple[float, float] | None = None, kappa: np.ndarray | None = None,
             reach: float = START_REACH) -> EdgeFit | None:
    """Fit the edge model to one frame around ``centre`` (px; ``bg`` the background model
    scaled to the frame, ``velocity`` px per frame) from a first radius ``r0``; with ``held =
    (sigma, exposure, az, el)`` the blur, exposure and light's direction are held, with
    ``light = (az, el)`` the light's direction; ``kappa``: the background's variance in units
    of the frame's noise variance, a map (:func:`._edge_kernel.varpro`; None: the background
    taken as exact); ``reach``: how far (px) beyond ``1.25 r0`` the starting grid reads where
    nothing is held (:func:`_start`). None if the pixels leave the frame or the fit fails."""
    speed = math.hypot(*velocity)
    q = np.array([centre[0], centre[1], r0, *held]) if held else \
        _start(img, bg, centre, velocity, r0, kappa, reach)
    if q is None:
        return None
    fixed = np.zeros(7, bool) if held is None else np.array([0, 0, 0, 1, 1, 1, 1], bool)
    lo = np.array([q[0] - 2, q[1] - 2, 0.75 * q[2], 0.05, 0.0, -2.0 * math.pi, 0.0])
    hi = np.array([q[0] + 2, q[1] + 2, 1.3 * q[2], 3.0, 1.0 if speed > 0.2 else 1e-3,
                   2.0 * math.pi, 0.5 * math.pi])
    if held is None and (light is not None or r0 < SHADOW_MIN_RADIUS):
        fixed[5:] = True  # the light given, or no shadow (elevation pi/2, from _start)
        if light is not None:
            q[5:] = light
    elif held is None:
        # the light's direction: the model without a shadow fitted first, then the best of a
        # grid of directions there (from the grid's start the fits ended 40-60 degrees from
        # the light, in local minima, on a noisy side-lit 15 px ball blurred by 1.5 px)
        lit = _light_start(img, bg, q, velocity, lo, hi, kappa)
        if lit is None:
            return None
        fixed[5:] = lit[6] == _NO_SHADOW
        # without a shadow, from the grid's start as before (where the cost is flat in the
        # radius the fit's path moves it: a ball lit from the camera, 10 px, blur 0.7 px:
        # -0.1 and -0.3 % from the grid, -0.6 and -0.8 % from the first fit without a shadow)
        q = q if fixed[5] else lit
    from ._edge_kernel import SECTORS

    res = px = None
    drop = np.zeros(SECTORS, np.bool_)
    for _ in range(2):  # twice: the pixels are chosen again from the first fit
        px = _rim_pixels(img, bg, q, velocity, kappa)
        if px is None or px.u.size < 40:
            return None
        q = np.where(fixed, q, np.clip(q, lo + 1e-9, hi - 1e-9))  # held: as given (pi/2)
        try:
            q, px, res = _robust_solve(px, q, fixed, lo, hi, drop)
            q, px, res = _without_misfit(px, q, velocity, fixed, lo, hi, drop, res)
        except np.linalg.LinAlgError:
            return None
    assert res is not None and px is not None
    rms = math.sqrt(float(res @ res) / max(float(px.weight.sum()), 1.0))
    cx, cy, r, sigma, exposure, az, el = (float(v) for v in q)
    return EdgeFit(cx, cy, r, sigma, exposure, rms, az, el, drop if drop.any() else None)


def _robust_solve(px: _Pixels, q: np.ndarray, fixed: np.ndarray, lo: np.ndarray,
                  hi: np.ndarray, drop: np.ndarray) -> tuple[np.ndarray, _Pixels, np.ndarray]:
    """:func:`_solve` of the parameters not ``fixed`` on the pixels ``px`` outside the polar
    sectors ``drop``, then again with the pixels the smooth model cannot follow (beyond 4
    robust SDs) left out too: the parameters, the pixels so weighted and their residuals."""
    from ._edge_kernel import in_sectors

    kept = ~in_sectors(px.u - q[0], px.v - q[1], drop)
    px = px._replace(weight=kept.astype(np.float64))
    q, res = _solve(px, q, ~fixed, lo, hi)
    scale = 1.4826 * float(np.median(np.abs(res[kept]))) + 1e-9
    px = px._replace(weight=((np.abs(res) <= 4.0 * scale) & kept).astype(np.float64))
    q, res = _solve(px, q, ~fixed, lo, hi)
    return q, px, res


def _sector_scores(px: _Pixels, q: np.ndarray, velocity, drop: np.ndarray | None
                  ) -> np.ndarray:
    """How far each polar sector of the rim misfits at ``q = (cx, cy, r, sigma, exposure,
    az, el)`` (:func:`._edge_kernel.sector_misfit`: the mean residual of its pixels inside the
    blurred rim over the ball's contrast), every pixel of ``px`` weighed alike; zero in the
    sectors ``drop`` (None: none)."""
    from scipy.special import ndtr

    from ._edge_kernel import SECTORS, sector_misfit

    res = _residual(q, px._replace(weight=np.ones(px.u.size)))
    du, dv = px.u - q[0], px.v - q[1]
    score = np.zeros(SECTORS)
    sector_misfit(res, px.grey, px.bg, ndtr((q[2] - np.hypot(du, dv)) / _blur(q, velocity)),
                  du, dv, float(q[2]), score)
    return score if drop is None else np.where(drop, 0.0, score)


def _without_misfit(px: _Pixels, q: np.ndarray, velocity, fixed: np.ndarray, lo: np.ndarray,
                    hi: np.ndarray, drop: np.ndarray, res: np.ndarray
                    ) -> tuple[np.ndarray, _Pixels, np.ndarray]:
    """The fit ``q`` (its pixels ``px``, residuals ``res``) again without the run of polar
    sectors about the worst where one misfits by more than ``EDGE_MISFIT`` of the ball's
    contrast (:func:`_sector_scores`, :func:`._edge_kernel.grow_run`), up to
    ``MISFIT_ROUNDS`` times; the sectors left out added to ``drop``. A logo near the rim takes
    a bite out of it, which the radius follows (docs/tracking.md §1)."""
    from ._edge_kernel import MISFIT_ROUNDS, grow_run

    for _ in range(MISFIT_ROUNDS):
        score = _sector_scores(px, q, velocity, drop)
        worst = int(np.argmax(np.abs(score)))
        if abs(score[worst]) <= EDGE_MISFIT or not grow_run(score, worst, drop):
            break
        q, px, res = _robust_solve(px, q, fixed, lo, hi, drop)
    return q, px, res


# starting radii, in units of the coverage radius: 0.8-1.25, and down to 0.55 because a
# blur inflates the coverage radius (+51 % for a dark 5 px ball blurred by 1.5 px on a plain
# wall, where a start of 0.8 or more led the fit to a wrong minimum: +54 %; docs/tracking.md §3)
_START_RADII = np.concatenate([[0.55, 0.62, 0.69, 0.76], np.linspace(0.8, 1.25, 8)])


# the light's directions tried at the start (radians; elevation pi/2: lit from the camera,
# no shadow at the rim)
# (the cost has local minima in the azimuth ~40 degrees apart: the rim's harmonics of order 2-4
# take up part of the shadow's profile around the rim, so a grid 45 degrees apart missed the
# light by 35-80 degrees on a ball lit from the right, radius -1.1 %; 15 degrees apart, on
# every other pixel)
_START_ELEVATIONS = (0.35, 0.75, 1.15)
_START_AZIMUTHS = np.radians(np.arange(-180.0, 180.0, 15.0))
_NO_SHADOW = 0.5 * math.pi


def _every_other(px: _Pixels) -> _Pixels:
    """Every other pixel of ``px`` (one frame's), in contiguous arrays (strided ones made the
    compiled kernel compile another version on the first video with a large ball, after
    ``bouncebayes warmup``)."""
    half: dict[str, Any] = {name: np.ascontiguousarray(getattr(px, name)[::2])
                            for name in _PER_PIXEL}
    return px._replace(**half)


def _light_start(img, bg, q, velocity, lo, hi, kappa: np.ndarray | None
                 ) -> np.ndarray | None:
    """``q`` with the centre, radius, blur and exposure fitted without a shadow, and the
    light's direction the best of ``_START_AZIMUTHS`` x ``_START_ELEVATIONS`` there, or none
    (elevation pi/2) where that is not better by ``SHADOW_MIN_GAIN`` or the blur is above
    ``SHADOW_MAX_BLUR`` of the radius."""
    px = _rim_pixels(img, bg, q, velocity, kappa)
    if px is None or px.u.size < 40:
        return None
    free = np.array([1, 1, 1, 1, 1, 0, 0], bool)
    q = np.clip(q, lo + 1e-9, hi - 1e-9)
    q[6] = _NO_SHADOW
    try:
        q = _solve(px, q, free, lo, hi)[0]
    except np.linalg.LinAlgError:
        return None
    if q[3] > SHADOW_MAX_BLUR * q[2]:  # blurred for its size: no shadow
        q[5:] = 0.0, _NO_SHADOW
        return q
    best, q_lit = math.inf, q.copy()
    px = _every_other(px)
    try:
        none = float(np.sum(_residual(q, px) ** 2))
    except np.linalg.LinAlgError:
        return None
    for az in _START_AZIMUTHS:
        for el in _START_ELEVATIONS:
            q[5:] = az, el
            try:
                cost = float(np.sum(_residual(q, px) ** 2))
            except np.linalg.LinAlgError:
                continue
            if cost < best:
                best, q_lit = cost, q.copy()
    # the shadow only where the pixels call for it: its fall in the cost, in units of the
    # residual variance, at least SHADOW_MIN_GAIN (else its parameters only trade against the
    # radius)
    if not (none - best) * px.u.size > SHADOW_MIN_GAIN * best:
        q_lit[5:] = 0.0, _NO_SHADOW
    return q_lit


def _start(img, bg, centre, velocity, r0: float, kappa: np.ndarray | None,
           reach: float = START_REACH) -> np.ndarray | None:
    """The best starting ``(cx, cy, r, sigma, exposure, az, el)`` on a grid of radius and
    blur (centre held, no shadow: the edge model has local minima where a blur trades
    against the shading near the rim)."""
    px = _pixels(img, bg, centre, velocity, 1.25 * r0, 1.25 * r0, reach,
                 r0 >= OCCLUSION_MIN_RADIUS, kappa)
    if px is None or px.u.size < 40:
        return None
    best, q_best = math.inf, None
    for sigma in (0.2, 0.7, 1.3):
        # every radius with every blur: the low radii only with the largest blur (where a blur
        # makes the coverage radius that much larger) saves 3 % of the 224 x 64 benchmark's
        # time but moves a side-lit 5 px ball's centres by 0.05 px (tests/test_tracking.py::
        # test_a_small_side_lit_balls_centres_are_not_pulled_to_the_lit_side: 0.080 -> 0.131)
        for r in r0 * _START_RADII:
            q = np.array([centre[0], centre[1], r, sigma, 0.0, 0.0, _NO_SHADOW])
            try:
                cost = float(np.sum(_residual(q, px) ** 2))
            except np.linalg.LinAlgError:
                continue
            if cost < best:
                best, q_best = cost, q
    return q_best


def _shared_light(args, fits: list[EdgeFit], kappa: np.ndarray | None
                  ) -> tuple[float, float]:
    """The light's direction ``(az, el)`` of the video, of those the first fits found.

    The one of the directions of ``fits`` (on the frames ``args``) that fits those frames best
    together, each frame's cost at its own fit's other parameters in units of its residual
    variance. (The frames' own directions scatter between the cost's local minima in the
    azimuth, ~40 degrees apart; their mean fell between them: a ball lit from the right, 14
    degrees, came out at 30-48, the radius -0.3 to -0.9 %; with this, 12-16 and -0.1 to
    -1.0 %.)"""
    frames = []  # each frame's fit (its light to be replaced) and pixels
    for (img, bg, _, v), f in zip(args, fits, strict=True):
        q = np.array([f.cx, f.cy, f.r, f.sigma, f.exposure, f.az, f.el])
        px = _rim_pixels(img, bg, q, v, kappa)
        if px is not None:
            frames.append((q, px, f.rms ** 2 * px.u.size + 1e-9))
    best, light = math.inf, (fits[0].az, fits[0].el)
    for cand in fits:
        total = 0.0
        for q, px, scale in frames:
            q[5:] = cand.az, cand.el
            try:
                total += float(np.sum(_residual(q, px) ** 2)) / scale
            except np.linalg.LinAlgError:
                total = math.inf
        if total < best:
            best, light = total, (cand.az, cand.el)
    return light


def _stack(pxs: Sequence[_Pixels]) -> _Pixels:
    """The pixels of several frames as one set (frame ``k`` the ``k``-th's; each pixel keeps
    its frame's centre in ``cx, cy``)."""
    joined: dict[str, Any] = {name: np.concatenate([getattr(p, name) for p in pxs])
                              for name in _PER_PIXEL}
    every = pxs[0]._replace(**joined)
    frame = np.concatenate([np.full(p.u.size, k, np.intp) for k, p in enumerate(pxs)])
    return every._replace(frame=frame, n_frames=len(pxs))


class JointFit(NamedTuple):
    """The frames fitted together (:func:`joint_radius`): the radius (px), each frame's
    centre ``(n, 2)`` (px), the blur (px) and the light's direction ``(az, el)`` (radians;
    elevation pi/2: no shadow) that fit them best, and the RMS residual of the pixels fitted
    (grey levels over the frames' gains)."""

    radius: float
    centres: np.ndarray
    sigma: float
    light: tuple[float, float]
    rms: float
    radius_sd: float = math.nan  # the radius' formal SE (px) where the blur was free with it


def _joint_pixels(args, fits: Sequence[EdgeFit], held: tuple[float, float, float, float],
                  kappa: np.ndarray | None, gains: np.ndarray, occlusion: bool | None = None
                  ) -> tuple[_Pixels, np.ndarray] | None:
    """The pixels of every frame of ``args`` as one set, each with the robust weights of its
    own fit ``fits`` under ``held``, and whether each is within ``SATURATED_REACH`` blurs of a
    saturated pixel; None where a frame's cannot be had. Each frame's grey levels are divided
    by ``gains`` (its gain times the ball's brightness against the wall's, :func:`_ball_levels`;
    its weights multiplied by it: the same cost), so that one shading of the ball holds every
    frame under a flickering lamp or a vignetting lens."""
    from ._edge_kernel import in_sectors

    sigma, exposure, az, el = held
    pxs, near = [], []
    for (img, bg, _, v), f, g in zip(args, fits, gains, strict=True):
        q = np.array([f.cx, f.cy, f.r, sigma, exposure, az, el])
        px = _rim_pixels(img, bg, q, v, kappa, occlusion)
        if px is None or px.u.size < 40:
            return None
        try:
            res = _residual(q, px)
        except np.linalg.LinAlgError:
            return None
        kept = np.ones(res.size, bool) if f.drop is None else \
            ~in_sectors(px.u - f.cx, px.v - f.cy, f.drop)
        scale = 1.4826 * float(np.median(np.abs(res[kept]))) + 1e-9
        pxs.append(px._replace(weight=g * ((np.abs(res) <= 4.0 * scale) & kept), grey=px.grey / g,
                               bg=px.bg / g, gbu=px.gbu / g, gbv=px.gbv / g))
        near.append(_near_saturated(img, px, math.ceil(SATURATED_REACH * _blur(q, v))))
    return _stack(pxs), np.concatenate(near)


INSIDE_BLURS = 2.5  # the ball's inside for its brightness: this many blurs inside the rim


def _ball_levels(args, fits: Sequence[EdgeFit], held: tuple[float, float, float, float],
                 gains: np.ndarray) -> np.ndarray:
    """Each frame's ball brightness relative to its gain (the wall's), over the median of the
    frames': a lens's vignetting or a lamp's fall-off lights the ball unlike the wall as it
    moves. From the mean grey level of the ball's inside (beyond ``INSIDE_BLURS`` blurs and
    0.5 px from its rim, where the ball alone is seen), weighted by ``(1 - (rho / r_in)^2)^2``
    so that the mean does not jump as pixels cross the circle. Ones where the inside is under
    1.5 px in radius or holds a saturated pixel (a highlight does not scale)."""
    sigma, exposure = held[:2]
    means = np.empty(len(args))
    for k, ((img, _, _, v), f) in enumerate(zip(args, fits, strict=True)):
        r_in = f.r - INSIDE_BLURS * _blur(np.array([f.cx, f.cy, f.r, sigma, exposure]), v) - 0.5
        u0, v0 = max(math.ceil(f.cx - r_in), 0), max(math.ceil(f.cy - r_in), 0)
        u1 = min(math.floor(f.cx + r_in) + 1, img.shape[1])
        v1 = min(math.floor(f.cy + r_in) + 1, img.shape[0])
        if r_in < 1.5 or u1 <= u0 or v1 <= v0:
            return np.ones(len(args))
        vv, uu = np.mgrid[v0:v1, u0:u1]
        w = np.clip(1.0 - ((uu - f.cx) ** 2 + (vv - f.cy) ** 2) / (r_in * r_in), 0.0, None) ** 2
        patch = img[v0:v1, u0:u1]
        if np.any((patch >= SATURATED) & (w > 0)):
            return np.ones(len(args))
        means[k] = float(np.sum(w * patch) / np.sum(w)) / gains[k]
    return means / np.median(means)


def _at_centres(every: _Pixels, c: np.ndarray) -> _Pixels:
    """``every`` with frame ``k``'s pixels centred on ``c[k]``."""
    return every._replace(cx=c[every.frame, 0], cy=c[every.frame, 1])


# the entries of (r, sigma, exposure, az, el) a joint fit may free
_JOINT_NAMES = ("r", "sigma", "exposure", "az", "el")


def _bounded_lm(fun_jac: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, x_scale: float, xtol: float,
                ftol: float, max_nfev: int) -> tuple[np.ndarray, float, int]:
    """Least squares by Levenberg-Marquardt within ``lo <= x <= hi`` on the normal equations
    (``fun_jac(x)``: the residuals and their Jacobian in one call): the bounded
    Levenberg-Marquardt of :func:`._edge_kernel.fit_frame` (its damping, bounds, stopping
    rules and scaled variables ``x / x_scale``) for the joint fits' ~60
    unknowns and ~20 000 residuals. Written here because SciPy's ``least_squares`` with
    bounds takes an SVD of the Jacobian at every step (0.3 s each, half the joint fit's CPU
    time) and evaluates the residuals and the Jacobian in separate calls (the model twice).
    Returns ``x``, its cost (half the sum of squares) and the status (-1: the start cannot be
    evaluated; else 0: evaluations, 1: gradient, 2: ``ftol``, 3: ``xtol``)."""
    x = np.clip(x0, lo, hi)
    start = _evaluated(fun_jac, x)
    if start is None:
        return x, math.inf, -1
    res, jac = start
    nfev, cost, lam, nu = 1, 0.5 * float(res @ res), -1.0, 2.0
    scale = 1.0 / x_scale  # the variables x / x_scale
    while True:
        js = jac / scale
        jtj, grad = js.T @ js, js.T @ res
        if np.abs(grad).max() < 1e-8:
            return x, cost, 1
        if lam < 0.0:
            lam = 1e-6 * float(np.diag(jtj).max())
        while True:
            if nfev >= max_nfev:
                return x, cost, 0
            proposal = _lm_step(x, lo, hi, jtj, grad, lam, scale)
            if proposal is None:  # a Jacobian with a NaN: no step can be found
                lam, nu = lam * nu, nu * 2.0
                if not lam < 1e300:
                    return x, cost, 1
                continue
            trial, predicted = proposal
            small = np.linalg.norm(trial - x) < xtol * (xtol + np.linalg.norm(x))
            at_trial = _evaluated(fun_jac, trial)
            nfev += 1
            actual = -math.inf if at_trial is None else cost - 0.5 * float(at_trial[0] @ at_trial[0])
            if at_trial is not None and predicted > 0.0 and actual > 1e-4 * predicted:
                rho = actual / predicted
                x, (res, jac) = trial, at_trial
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
                before, cost = cost, cost - actual
                if actual < ftol * before and rho > 0.25:
                    return x, cost, 2
                if small:
                    return x, cost, 3
                break
            if small:
                return x, cost, 3
            lam, nu = lam * nu, nu * 2.0


def _evaluated(fun_jac: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
               x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``fun_jac(x)``, or None where the model cannot be evaluated or is not finite there."""
    try:
        res, jac = fun_jac(x)
    except np.linalg.LinAlgError:
        return None
    return (res, jac) if np.all(np.isfinite(res)) else None


def _lm_step(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, jtj: np.ndarray,
             grad: np.ndarray, lam: float, scale: float
             ) -> tuple[np.ndarray, float] | None:
    """:func:`_bounded_lm`'s trial point from ``x`` (the normal equations ``jtj``, ``grad``
    in the scaled variables ``x * scale``, damping ``lam``) and the fall in cost it predicts;
    a variable at a bound that the gradient pushes outwards held there, the step clipped to
    the bounds. None where the damped equations are singular."""
    held = ((x <= lo + 1e-9 * (hi - lo)) & (grad > 0)) | ((x >= hi - 1e-9 * (hi - lo)) & (grad < 0))
    mat = np.where(held[:, None] | held[None, :], 0.0, jtj)
    mat[np.diag_indices_from(mat)] += np.where(held, 1.0, lam)
    try:
        step = np.linalg.solve(mat, np.where(held, 0.0, -grad))
    except np.linalg.LinAlgError:
        return None
    trial = np.clip(x + step / scale, lo, hi)
    step = (trial - x) * scale
    return trial, float(-(grad @ step + 0.5 * step @ jtj @ step))


def _joint_problem(every: _Pixels, q: np.ndarray, idx: list[int]
                   ) -> tuple[Callable[[np.ndarray], tuple[np.ndarray, _Pixels]],
                              Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]]:
    """The frames of ``every`` fitted together as a function of ``x``: the entries ``idx`` of
    ``q = (r, sigma, exposure, az, el)`` then every frame's centre. ``at(x)``: the full ``q``
    and the pixels at those centres; ``fun_jac(x)``: the weighted residuals and their Jacobian
    (the compiled model's, exact columns)."""
    n, p = every.n_frames, len(idx)
    free = np.zeros(7, bool)
    free[:2] = True
    free[[2 + i for i in idx]] = True

    def at(x: np.ndarray) -> tuple[np.ndarray, _Pixels]:
        qx = q.copy()
        qx[idx] = x[:p]
        return qx, _at_centres(every, x[p:].reshape(n, 2))

    def fun_jac(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        res, jc = _evaluate(*at(x), free, True, True)
        return res, np.hstack([jc[:, 2 * n:], jc[:, :2 * n]])

    return at, fun_jac


def _joint_radius_sd(every: _Pixels, q: np.ndarray, c: np.ndarray) -> float:
    """The Cramer-Rao bound (px) of the radius of the frames' joint fit at ``q = (r, sigma,
    exposure, az, el)``, centres ``c``: the radius, the blur and every frame's centre free, the
    linear coefficients (the shading, each frame's background levels) profiled out (the
    compiled model's Jacobian is the variable projection's, :func:`._edge_kernel.varpro`),
    the residuals' variance their mean square; inf where the information is singular. The
    NumPy model's numerical derivatives, the coefficients as parameters and no ridge, gave the
    same within 2 % on the scenes of docs/tracking.md §3, some 50 times slower."""
    idx = [0, 1]
    res, jac = _joint_problem(every, q, idx)[1](np.concatenate([q[idx], c.ravel()]))
    dof = max(int(np.count_nonzero(every.weight)) - jac.shape[1], 1)
    info = jac.T @ jac
    if np.linalg.matrix_rank(info) < info.shape[0]:
        return math.inf
    return math.sqrt(max(float(np.linalg.inv(info)[0, 0]) * float(res @ res) / dof, 0.0))


def _joint_solve(every: _Pixels, q: np.ndarray, c: np.ndarray, names: tuple[str, ...]
                 ) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The frames of ``every`` fitted together from ``q = (r, sigma, exposure, az, el)`` and
    their centres ``c`` ``(n, 2)``: the entries of ``q`` ``names``d and every frame's centre
    free (:func:`_bounded_lm` on the compiled model with the exact columns and its Jacobian,
    whose columns are each frame's ``(cx, cy)``, then the free entries of ``q`` in order). The
    best ``q``, centres and cost (half the sum of squares); None where the fit fails.

    Each frame's centre is always free: held at the first joint fit's while the blur and light
    were freed, the sweep's radii moved by up to 4 %."""
    n, idx = every.n_frames, [_JOINT_NAMES.index(name) for name in names]
    p = len(idx)
    at, fun_jac = _joint_problem(every, q, idx)
    lo_q = np.array([0.75 * q[0], 0.5 * q[1], 0.0, q[3] - math.pi, 0.02])
    hi_q = np.array([1.3 * q[0], 2.0 * q[1] + 0.1, 1.0, q[3] + math.pi, 1.5])
    lo = np.concatenate([lo_q[idx], c.ravel() - 2.0])
    hi = np.concatenate([hi_q[idx], c.ravel() + 2.0])
    x0 = np.clip(np.concatenate([q[idx], c.ravel()]), lo, hi)
    x, cost, status = _bounded_lm(fun_jac, x0, lo, hi, 0.05, 1e-6, 1e-8, 50)
    if status < 0 or not np.all(np.isfinite(x)):
        return None
    qx, _ = at(x)
    return qx, x[p:].reshape(n, 2), cost


# the light's directions tried on the frames together (radians): 30 degrees apart in the
# azimuth, the second fit takes it from there (with the columns blurred along the radius only
# this grid took an elevation of 11 degrees for a light at 50 on two of four side-lit 10 px
# balls under a 1.5 px blur; those needed 10 degrees x 5 elevations)
_JOINT_AZIMUTHS = np.radians(np.arange(-180.0, 180.0, 30.0))
_JOINT_ELEVATIONS = (0.2, 0.7, 1.2)


def _joint_light(every: _Pixels, q: np.ndarray, c: np.ndarray) -> tuple[float, float] | None:
    """The light's direction ``(az, el)`` that fits the frames of ``every`` best together at
    ``q`` and centres ``c``, of a grid (the exact columns: 36 evaluations); None where it
    lowers their cost by less than ``JOINT_SHADOW_MIN_FALL`` of it (no shadow to be seen)."""
    px = _at_centres(every, c)

    def cost(az: float, el: float) -> float:
        try:
            res = _evaluate(np.array([q[0], q[1], q[2], az, el]), px, _NONE_FREE, False,
                            True)[0]
        except np.linalg.LinAlgError:
            return math.inf
        return float(res @ res)

    none = cost(0.0, _NO_SHADOW)
    best, light = min((cost(float(az), el), (float(az), el)) for az in _JOINT_AZIMUTHS
                      for el in _JOINT_ELEVATIONS)
    if not none - best > JOINT_SHADOW_MIN_FALL * best:
        return None
    return light


def _joint_without_misfit(every: _Pixels, q: np.ndarray, c: np.ndarray) -> _Pixels | None:
    """``every`` with each frame's run of polar sectors about its worst left out where that
    misfits by more than ``EDGE_MISFIT`` of the ball's contrast under the frames' joint fit
    ``q = (r, sigma, exposure, az, el)``, centres ``c`` (scored as :func:`_sector_scores`; up to
    ``MISFIT_ROUNDS`` runs a frame); None where no frame's does. One shading shared by the
    frames cannot take up a logo near the rim as each frame's own shading does."""
    from scipy.special import ndtr

    from ._edge_kernel import MISFIT_ROUNDS, SECTORS, grow_run, in_sectors, sector_misfit

    px = _at_centres(every, c)
    res = _residual(q, px._replace(weight=np.ones(px.u.size)), exact=True)
    du, dv = px.u - px.cx, px.v - px.cy
    s = np.sqrt(q[1] ** 2 + 1.0 / 12.0 + (q[2] * px.speed) ** 2 / 12.0)
    step = ndtr((q[0] - np.hypot(du, dv)) / s)
    weight, changed = every.weight.copy(), False
    for k in range(every.n_frames):
        sel = np.flatnonzero(every.frame == k)
        score, drop = np.zeros(SECTORS), np.zeros(SECTORS, np.bool_)
        sector_misfit(res[sel], px.grey[sel], px.bg[sel], step[sel], du[sel], dv[sel],
                      float(q[0]), score)
        for _ in range(MISFIT_ROUNDS):
            worst = int(np.argmax(np.abs(np.where(drop, 0.0, score))))
            if drop[worst] or abs(score[worst]) <= EDGE_MISFIT or not grow_run(score, worst, drop):
                break
        if drop.any():
            weight[sel[in_sectors(du[sel], dv[sel], drop)]] = 0.0
            changed = True
    return every._replace(weight=weight) if changed else None


def joint_radius(args, fits: Sequence[EdgeFit], held: tuple[float, float, float, float],
                 kappa: np.ndarray | None, gains: Sequence[float] | None = None,
                 blur_free: bool = False) -> JointFit | None:
    """The radius that fits the frames ``args`` (image, background, centre, velocity) best
    together: one radius, blur, light and shading of the ball (its linear coefficients) for
    all, that shading times each frame's gain ``gains`` (default 1: the frame's brightness
    relative to the background model, lamp flicker), the exposure ``held``, each frame its
    own centre and local background levels; from
    the frames' own fits ``fits`` (their centres, the median radius; each frame's pixels and
    robust weights as its fit's) under ``held = (sigma, exposure, az, el)``. None where the
    fit fails.

    First the radius alone, the rest held (from three radii, the lowest cost kept); then, for a
    ball of ``SHADOW_MIN_RADIUS`` or more with a light (the held one, or where that has none
    the best of a grid, :func:`_joint_light`), the blur, the exposure and the light's direction
    free with it, and again without the pixels near a saturated one. Every stage with the
    columns blurred in two dimensions (``exact``, :func:`._edge_kernel._hankel`) and the
    compiled model's Jacobian (:func:`_bounded_lm`).

    Why: a frame alone hardly holds the radius where the blur is a large part of it (the
    shading's limb and level trade against a blurred step at another radius), and what it
    holds is biased by the noise: radius 10 px, blur 1.5 px (held at the truth), noise 3 grey
    levels, exact background: the frames' radii scatter by 3 % and their median sits +1.4 %
    out (a uniform dark disk; +3.7 % on benchmarks/tracking_accuracy.py's dark ball on a plain
    wall, seed 11); the ball's shading is the same in every frame (one lamp, far away), and
    shared it takes that freedom away. Frames alone do not find the light there (its shadow
    is within a blur or two of the rim, ``SHADOW_MAX_BLUR``), together they do, and the blur
    the frames' medians held is off by up to 0.1 px, a -2 / +2 % error in the radius
    (docs/tracking.md §1, *the frames together*, *the light and the blur of the frames
    together*, *the columns blurred in two dimensions*). The frames' own fits keep the columns
    blurred along the radius only (2-3x cheaper; their radius is not the one kept here)."""
    gain = np.ones(len(args)) if gains is None else np.asarray(gains, dtype=float)
    # a small ball's frames fitted with the blur free: with the wall's occlusion term (below)
    joined = _joint_pixels(args, fits, held, kappa, gain * _ball_levels(args, fits, held, gain),
                           True if blur_free else None)
    if joined is None:
        return None
    every, near_saturated = joined
    if (first := _joint_first(every, fits, held)) is None:
        return None
    every, (q, c, cost) = first
    out = JointFit(float(q[0]), c, float(q[1]), (float(q[3]), float(q[4])),
                   _rms(cost, every))
    if q[0] < SHADOW_MIN_RADIUS:
        return _small_blur_free(every, q, c) if blur_free else out
    if q[4] >= _NO_SHADOW:
        light = _joint_light(every, q, c)
        if light is None:  # no shadow: the blur as held (freed, it only scatters the radius)
            return out
        q[3:] = light
    # the blur, the exposure (the frames' held one came out 0.99 for a ball filmed at none)
    # and the light free with the radius; then again without the pixels within
    # SATURATED_REACH blurs of a saturated one: such a patch on a ball is mostly a specular
    # highlight, which no column holds, and the blur carries its light outwards (a glossy 10
    # px ball under a 1.5 px blur, one noise-free frame, tests/render_pbr.py: 15 grey levels
    # of it 2 px inside the rim; the radius +8.1 % without its neighbours, +3.3 % within 3
    # px, +0.03 % within 5 px, 3.3 blurs; a matte ball that saturates -0.16 -> -0.38 %; with
    # noise, on a plain wall, -5.0..+6.9 % over seven draws: without its lit side the radius
    # trades against the blur). The first fits and the light's grid keep them: without a
    # glossy ball's lit side the grid missed its light by ~105 degrees
    names = ("r", "sigma", "exposure", "az", "el")
    second = _joint_solve(every, q, c, names)
    if second is None:
        return out
    if np.any(near_saturated & (every.weight > 0)):
        clear = every._replace(weight=np.where(near_saturated, 0.0, every.weight))
        if (third := _joint_solve(clear, *second[:2], names)) is not None:
            every, second = clear, third
    q, c, cost = second
    az = math.remainder(float(q[3]), 2.0 * math.pi)  # the fit may carry it past +-pi
    return JointFit(float(q[0]), c, float(q[1]), (az, float(q[4])), _rms(cost, every))


def _joint_first(every: _Pixels, fits: Sequence[EdgeFit],
                 held: tuple[float, float, float, float]
                 ) -> tuple[_Pixels, tuple[np.ndarray, np.ndarray, float]] | None:
    """The first stage of :func:`joint_radius`: the radius alone free (and the centres), the
    rest ``held``, from the frames' median radius and ``JOINT_STARTS`` of it (the joint cost
    has more than one minimum in the radius: a ball lit from the camera, 10 px, blur 0.7 px,
    plain wall, at +0.4 and +4.3 %, the second reached from the frames' median), the lowest
    kept; then again without each frame's sectors that misfit under it
    (:func:`_joint_without_misfit`). The pixels so weighted and the fit; None where it fails."""
    median = float(np.median([f.r for f in fits]))
    starts = [_joint_solve(every, np.array([median * k, *held]),
                           np.array([[f.cx, f.cy] for f in fits]), ("r",))
              for k in JOINT_STARTS]
    found = [s for s in starts if s is not None]
    if not found:
        return None
    q, c, cost = min(found, key=lambda s: s[2])
    cleaner = _joint_without_misfit(every, q, c)
    if cleaner is not None and (again := _joint_solve(cleaner, q, c, ("r",))) is not None:
        return cleaner, again
    return every, (q, c, cost)


def _small_blur_free(every: _Pixels, q: np.ndarray, c: np.ndarray) -> JointFit | None:
    """The frames of ``every`` fitted together with the radius and the blur free, from ``q``
    and centres ``c``, for a small ball blurred by a large part of its radius: its
    ``radius_sd`` the Cramer-Rao bound there (:func:`_joint_radius_sd`); None where the fit
    fails or the wall's texture the ball hides gives less than ``JOINT_TEXTURE_GAIN`` of
    that information (the bound with each frame's background made flat over the bound)."""
    again = _joint_solve(every, q, c, ("r", "sigma"))
    if again is None:
        return None
    q, c, cost = again
    sd = _joint_radius_sd(every, q, c)
    level = np.array([np.median(every.bg[every.frame == k]) for k in range(every.n_frames)])
    flat = _joint_radius_sd(every._replace(bg=level[every.frame]), q, c)
    if not flat >= JOINT_TEXTURE_GAIN * sd:
        return None
    return JointFit(float(q[0]), c, float(q[1]), (float(q[3]), float(q[4])), _rms(cost, every),
                    sd)


def _rms(cost: float, px: _Pixels) -> float:
    """The RMS residual of the pixels ``px`` fitted (their weights) at ``cost`` (half the sum
    of squares)."""
    return math.sqrt(2.0 * cost / max(float(px.weight.sum()), 1.0))


# frames, backgrounds, centres (px), velocities (px per frame) and gains of the frames fitted
_FrameInputs = tuple[Sequence[np.ndarray], Sequence[np.ndarray], np.ndarray, np.ndarray,
                     Sequence[float]]


def _held_fits(args, first: dict[int, EdgeFit | None], r1: float,
               held: tuple[float, float, float, float], kappa: np.ndarray | None
               ) -> list[EdgeFit | None]:
    """Every frame of ``args`` fitted from radius ``r1`` with the blur, exposure and light
    ``held`` (from its free fit's centre where ``first`` has one; None where that failed: a
    frame the model cannot follow)."""
    second: list[EdgeFit | None] = []
    for i, (img, bg, c, v) in enumerate(args):
        f = first.get(i)
        if i in first and f is None:
            second.append(None)
        else:
            second.append(fit_edge(img, bg, c if f is None else (f.cx, f.cy), v, r1,
                                   held=held, kappa=kappa))
    return second


# A misfit: the free fits' median RMS residual above MISFIT times the frames' noise (the
# background difference's robust SD). On 22 rendered clips of balls without a cast shadow
# (benchmarks/tracking_accuracy.py's scenes, radius 5-15 px, blur 0-1.5 px, MJPEG, MPEG-4) it
# was 0.9-1.8 (above 1 on a bright ball: its own shot noise); where a dark ball's shadow cast
# on the wall beside it by a lamp merged with it, 2.2-3.4. There the coverage took ball and
# shadow for one blob (a 12 px ball of albedo 0.2 on a wall of 200 grey levels, a shadow of
# 0.5-0.9 of the wall's light offset by 0.78 radii: coverage radius +25 %, centroid 4 px
# towards the shadow) and the edge model fitted from it settled on one larger disk (radius +31
# to +39 %, centres 4.3 px off, RMS residual 8-10 grey levels for noise 3). From starts
# RESTART_AWAY coverage radii from the centroid in RESTART_DIRECTIONS directions, with
# RESTART_RADIUS of its radius, the one towards the ball found it (RMS 2.9, centres 0.05 px)
# and the shadow's own disk a worse fit (RMS 4.3-5.3). So where the free fits misfit, each is
# fitted again from those starts and the best kept where its RMS residual is below
# RESTART_BETTER of the first's; and where the free fits' centres are then RESTART_SHIFT radii
# or more from the centroids alike, every frame is fitted from its centroid so moved.
MISFIT = 2.0
RESTART_AWAY = 0.3
RESTART_DIRECTIONS = 8
RESTART_RADIUS = 0.8
RESTART_BETTER = 0.8
# ... and there the starting grid reads RESTART_REACH px beyond its largest radius, not
# START_REACH: at 8 px the shadow lies within START_REACH of the ball's rim on its side, and
# from the true centre the grid's best radius took it in (10.0 px for 8; fitted 10.5, RMS 6.3;
# reading RESTART_REACH px out, 7.97 px, RMS 2.9)
RESTART_REACH = 4.0
RESTART_SHIFT = 0.1  # (a ball's centroids are 0.3-0.5 px off at 12 px, blur 0.7, exposure 0.3)


def _restarted(img, bg, centre, velocity, r0: float, fit: EdgeFit | None,
               kappa: np.ndarray | None) -> EdgeFit | None:
    """The best of the free fits from ``RESTART_DIRECTIONS`` starts ``RESTART_AWAY r0``
    around ``centre`` (radius ``RESTART_RADIUS r0``) that found the ball elsewhere
    (``RESTART_SHIFT r0`` or more from ``fit``'s centre), where its RMS residual is below
    ``RESTART_BETTER`` of ``fit``'s; else ``fit``. A ball with marks on it misfits too, and
    there the same ball fitted again from elsewhere moved the radius (a striped 10 px ball of
    benchmarks/tracking_centres.py, +2.43 -> +3.20 %; found elsewhere only, +2.62 %, and the
    four striped clips' fitted centres at most 0.33 px off, 0.43 before the restarts)."""
    best = fit
    for angle in np.arange(RESTART_DIRECTIONS) * (2.0 * math.pi / RESTART_DIRECTIONS):
        start = (centre[0] + RESTART_AWAY * r0 * math.cos(angle),
                 centre[1] + RESTART_AWAY * r0 * math.sin(angle))
        other = fit_edge(img, bg, start, velocity, RESTART_RADIUS * r0, kappa=kappa,
                         reach=RESTART_REACH)
        elsewhere = fit is None or other is not None and \
            math.dist((other.cx, other.cy), (fit.cx, fit.cy)) >= RESTART_SHIFT * r0
        if other is not None and elsewhere and (best is None or other.rms < best.rms):
            best = other
    if fit is None or (best is not None and best.rms < RESTART_BETTER * fit.rms):
        return best
    return fit


def _centroid_shift(args, first: dict[int, EdgeFit | None]) -> np.ndarray | None:
    """The free fits' median offset (px) from their frames' centres in ``args``, where it is
    ``RESTART_SHIFT`` of their median radius or more (None where it is less)."""
    ok = [(i, f) for i, f in first.items() if f is not None]
    if not ok:
        return None
    shift = np.median([(f.cx - args[i][2][0], f.cy - args[i][2][1]) for i, f in ok], axis=0)
    if math.hypot(*shift) < RESTART_SHIFT * float(np.median([f.r for _, f in ok])):
        return None
    return shift


def _moved(args, shift: np.ndarray | None) -> list:
    """``args`` with each frame's centre moved by ``shift`` (px; as given where None)."""
    if shift is None:
        return list(args)
    return [(img, bg, np.asarray(c, dtype=float) + shift, v) for img, bg, c, v in args]


def _shared(args: list[tuple[np.ndarray, np.ndarray, Any, Any]],
            first: dict[int, EdgeFit | None], r0: float, kappa: np.ndarray | None,
            reach: float) -> tuple[tuple[float, float, float, float], float]:
    """The blur, exposure and light ``(sigma, exposure, az, el)`` the frames ``args`` share
    (one lens, one exposure, one lamp), and the radius to start their held fits from, of
    their free fits ``first``: a shadow if most of them found one, the light then the one of
    their directions that fits their frames best together and those frames fitted again
    under it (from ``r0``, the starting grid reading ``reach`` px out); the medians of the
    frames that agree."""
    fits = {i: f for i, f in first.items() if f is not None}
    index = list(fits)
    ok = [index[k] for k in _alike(list(fits.values()))]  # the frames alike
    shadow = [i for i in ok if fits[i].el < _NO_SHADOW]
    if 2 * len(shadow) > len(ok):  # the shadow frames again with their light: blur, exposure
        light = _shared_light([args[i] for i in shadow], [fits[i] for i in shadow], kappa)
        again = [fit_edge(*args[i], r0, light=light, kappa=kappa, reach=reach) for i in shadow]
        agree = [f for f in again if f is not None] or [fits[i] for i in shadow]
    else:
        light = (0.0, _NO_SHADOW)
        agree = [fits[i] for i in ok if fits[i].el >= _NO_SHADOW]
    return ((float(np.median([f.sigma for f in agree])),
             float(np.median([f.exposure for f in agree])), *light),
            float(np.median([f.r for f in agree])))


ALIKE = 0.1  # fits whose radius is off the median by more than this fraction ...
ALIKE_RMS = 1.3  # ... or whose RMS residual is this times the median's or more are left out
# ... of a ball larger than this (px); a smaller one's fits scatter beyond ALIKE (the paper's
# camera, benchmarks/paper_camera.py: a 5 px ball in MPEG-4 had one left out, and the blur the
# rest held put its radius at +8.2 % against +2.3 %; glossy 5 px balls under a 1.5 px blur,
# benchmarks/tracking_accuracy.py, -17.4 -> -19.5 %)
ALIKE_MIN_RADIUS = 8.0


def _alike(fits: list[EdgeFit]) -> list[int]:
    """The indices of the fits whose radius is within ``ALIKE`` of their median and whose RMS
    residual is under ``ALIKE_RMS`` times their median (all of them where fewer than 3 are, or
    where that median radius is at most ``ALIKE_MIN_RADIUS``): a frame whose ball is partly
    hidden (a frame counter burned in across its path, tests/render_pbr.py's
    scene, MJPEG: free fits' radii -34 and -18 %, blurs 1.82 px against 0.69-0.75, neither
    with the light's shadow) must not set the blur and light the others share (those two and
    a third without the shadow outvoted two with it: every frame then fitted with a 1.82 px
    blur and no light, the radius -13 %, the centres 0.3-1.2 px off), nor pull the frames'
    joint fit (uncompressed, held fits 1.5-4 % small at 1.41-1.44 times the median RMS, the
    others' at most 1.08: the joint radius -1.6 %)."""
    every = list(range(len(fits)))
    if len(fits) < 3:
        return every
    r, rms = np.median([f.r for f in fits]), np.median([f.rms for f in fits])
    if r <= ALIKE_MIN_RADIUS:
        return every
    alike = [k for k, f in enumerate(fits) if abs(f.r / r - 1) <= ALIKE and f.rms < ALIKE_RMS * rms]
    return alike if len(alike) >= 3 else every


def _free_fits(args: Sequence[tuple[Any, Any, Any, Any]], r0: float,
               kappa: np.ndarray | None, noise: float | None
               ) -> tuple[dict[int, EdgeFit | None], float]:
    """The free fits (all seven parameters, most of the cost) on up to ``FIRST_FRAMES`` of the
    frames ``args``, spread: they only set the shared blur, exposure, light and the starting
    radius; and how far beyond the rim the free fits to come read (px). Where they misfit (a
    shadow beside the ball merged with it: ``MISFIT``) from other starts (:func:`_restarted`),
    and the fits to come read less of the wall (``RESTART_REACH``)."""
    first = {int(i): fit_edge(*args[int(i)], r0, kappa=kappa)
             for i in spread(len(args), FIRST_FRAMES)}
    ok = [f for f in first.values() if f is not None]
    if noise is not None and len(ok) >= 3 and np.median([f.rms for f in ok]) > MISFIT * noise:
        return {i: _restarted(*args[i], r0, f, kappa) for i, f in first.items()}, RESTART_REACH
    return first, START_REACH


def _held_cast(args, found: tuple[CastShadow, dict[int, np.ndarray], float],
               first: dict[int, EdgeFit | None], kappa: np.ndarray | None, reach: float
               ) -> tuple[CastShadow, list, np.ndarray, float, dict[int, EdgeFit | None]]:
    """Where the ball's shadow hugs its edge (``found``, :func:`._cast.find_cast`): the shadow,
    the frames ``args`` at the centres found with it (backgrounds as given) and how far they
    moved (px), the radius found with it, and the free fits again with the shadow painted into
    every background, from that radius (a dark ball's coverage took the shadow in: +26 %)."""
    cast, at, r0 = found
    plain, moved = at_centres(args, at)
    shaded = painted(plain, cast)
    again = {i: fit_edge(*shaded[i], r0, kappa=kappa, reach=reach) for i in first}
    return cast, plain, moved, r0, again


def _agreeing(joint: JointFit | None, sigma: float, rms: float) -> JointFit | None:
    """``joint`` where its blur is within ``JOINT_BLUR_AGREE`` of the frames' held ``sigma``
    and its RMS residual under ``JOINT_RMS`` times theirs, ``rms``; else None."""
    if joint is None or abs(joint.sigma / sigma - 1.0) > JOINT_BLUR_AGREE or \
            joint.rms > JOINT_RMS * rms:
        return None
    return joint


def _joint_alike(args, fits: list[EdgeFit], held: tuple[float, float, float, float],
                 kappa: np.ndarray | None, gain: list[float], med: float, centres: np.ndarray,
                 blur_free: bool = False
                 ) -> tuple[float, tuple[float, float, float, float], float | None]:
    """:func:`joint_radius` of the frames ``args`` whose fits ``fits`` are alike
    (:func:`_alike`: a partly hidden ball's would pull them all): the radius, what the
    frames share and, where the blur was free with it (``blur_free``), the radius' standard
    error, its centres written into ``centres`` (one row per fit); ``med``, ``held`` and None
    as given where the joint fit fails or its blur is not the frames' (by
    ``JOINT_BLUR_AGREE``: their look is not shared) or it misfits (``JOINT_RMS``)."""
    keep = _alike(fits)
    rms = float(np.median([fits[k].rms for k in keep]))
    sub = ([args[k] for k in keep], [fits[k] for k in keep], held, kappa,
           [gain[k] for k in keep])
    joint = _agreeing(joint_radius(*sub, blur_free), held[0], rms)
    if blur_free and joint is None and held[0] <= MORE_FRAMES_MAX_BLUR * med:
        # not held so (a plain wall): the radius alone, the blur held, as below WIDE_BLUR
        joint = _agreeing(joint_radius(*sub), held[0], rms)
    if joint is None:
        return med, held, None
    centres[keep] = joint.centres
    se = joint.radius_sd if math.isfinite(joint.radius_sd) else None
    return joint.radius, (joint.sigma, held[1], *joint.light), se


def _more_frames(args: list, gain: list[float], first: dict[int, EdgeFit | None],
                 inputs: _FrameInputs, moved: np.ndarray, cast: CastShadow | None, r0: float,
                 kappa: np.ndarray | None, reach: float) -> tuple[list, list[float]]:
    """``args`` and ``gain`` with the frames ``inputs`` added (their centres ``moved``, the
    ball's shadow ``cast`` painted into their backgrounds), and free fits of them added to
    ``first`` up to ``FIRST_FRAMES_BLURRED`` in all (from ``r0``, reading ``reach`` px)."""
    *frames, extra_gains = inputs
    extra, n = painted(_moved(zip(*frames, strict=True), moved), cast), len(args)
    every: list[tuple[np.ndarray, np.ndarray, Any, Any]] = [*args, *extra]
    for i in n + spread(len(extra), FIRST_FRAMES_BLURRED - len(first)):
        first[int(i)] = fit_edge(*every[int(i)], r0, kappa=kappa, reach=reach)
    return every, gain + list(extra_gains)


def fit_radius(frames: Sequence[np.ndarray], backgrounds: Sequence[np.ndarray],
               centres: np.ndarray, velocities: np.ndarray, gains: Sequence[float], r0: float,
               more: Callable[[], _FrameInputs] | None = None,
               kappa: np.ndarray | None = None, noise: float | None = None
               ) -> RadiusFit | None:
    """The ball's radius from the frames given (each with the ball wholly in view near
    ``centres``, px; ``backgrounds``: the background model scaled to each frame;
    ``velocities``: px per frame; ``gains``: each frame's brightness relative to the
    background model, which the frames fitted together scale the ball's shading by): up to
    ``FIRST_FRAMES`` of them fitted alone, then every
    frame with the blur, exposure and light held at those fits' (medians; the light: see
    below); the median radius and its standard error. Where those first fits find a blur of
    ``BLURRED`` to ``MORE_FRAMES_MAX_BLUR`` of the radius, ``more()`` gives more frames (the
    same five sequences; ``RadiusFit.frames`` then counts them after the frames given), up to
    ``FIRST_FRAMES_BLURRED`` in all are fitted alone and every frame with the blur held, and
    the radius and centres are those of the frames fitted together (:func:`joint_radius`; the
    standard error stays the median's; the blur and light then the joint fit's).
    ``kappa``: the backgrounds' variance in units of the frames' noise variance, one map for
    the video (:func:`fit_edge`). ``noise``: the frames' noise (grey levels; None: not known),
    against which the free fits' residual tells a misfit (``MISFIT``: the frames are then
    fitted again from other starts, :func:`_restarted`). None if fewer than 3 frames could be
    fitted."""
    args, gain = list(zip(frames, backgrounds, centres, velocities, strict=True)), list(gains)
    first, reach = _free_fits(args, r0, kappa, noise)
    ok = [f for f in first.values() if f is not None]
    if len(ok) < 3:
        return None
    # ``plain``: the frames with their centres as moved, the backgrounds as given; ``moved``:
    # how far every centre was moved (px), which the frames to come are moved by too
    plain, cast, moved = args, None, np.zeros(2)
    if (found := find_cast(args, first)) is not None:
        cast, plain, moved, r0, first = _held_cast(args, found, first, kappa, reach)
        args, ok = painted(plain, cast), [f for f in first.values() if f is not None]
        if len(ok) < 3:
            return None
    shift = _centroid_shift(args, first)
    if shift is not None:  # the centroids are off alike: every frame from its centroid moved
        plain, moved = _moved(plain, shift), moved + shift
        args, r0 = painted(plain, cast), float(np.median([f.r for f in ok]))
    blur = float(np.median([f.sigma for f in ok]) / np.median([f.r for f in ok]))
    # a small ball blurred by a large part of its radius: the frames together, blur free
    wide = blur > WIDE_BLUR and np.median([f.r for f in ok]) < SHADOW_MIN_RADIUS
    if more is not None and BLURRED <= blur and (blur <= MORE_FRAMES_MAX_BLUR or wide):
        # blurred for its size: the blur the fits hold sets the radius; more frames for it
        args, gain = _more_frames(args, gain, first, more(), moved, cast, r0, kappa, reach)
    held, r1 = _shared(args, first, r0, kappa, reach)
    second = _held_fits(args, first, r1, held, kappa)
    fits = [f for f in second if f is not None]
    if len(fits) < 3:
        return None
    med, se = median_and_se(np.array([f.r for f in fits]))
    used = [i for i, f in enumerate(second) if f is not None]
    centres = np.array([[f.cx, f.cy] for f in fits])
    method = EDGE_MODEL
    if BLURRED <= held[0] / med and (held[0] / med <= MORE_FRAMES_MAX_BLUR or wide):
        # blurred for its size: the frames together (the SE stays the frames' scatter's, but
        # for a small ball's whose blur was free with it: its Cramer-Rao bound)
        med, held, joint_se = _joint_alike([args[i] for i in used], fits, held, kappa,
                                           [gain[i] for i in used], med, centres, wide)
        if joint_se is not None:
            se, method = joint_se, JOINT_FIT
    return RadiusFit(med, se, held[0], held[1], float(np.median([f.rms for f in fits])),
                     tuple(used), centres, light=held[2:], method=method,
                     radii=tuple(f.r for f in fits), cast=cast)

