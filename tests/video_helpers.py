"""Synthetic high-speed videos of a bouncing ball, rendered from a known trajectory.

The scene imitates the paper's set-up (§3: a 25.6 mm ball filmed at 1000 fps bouncing on an
inclined plane): a shaded ball (radial grey-level gradient, anti-aliased edge) over a textured
background (seeded smoothed noise), with the inclined plane below its surface line (a striped
"wood" texture and a bright edge highlight). Optional: motion blur (the exposure is averaged over
sub-frame renders), Gaussian pixel noise, a soft shadow that follows the ball and lamp flicker.

The trajectory is exact: ballistic in, an instantaneous bounce (normal and tangential velocity
ratios), ballistic out, in the plane-aligned frame (``x`` along the plane in the direction of
travel, ``y`` along the outward normal), mapped to pixels by a rotation and a scale. Frame ``k``
is exposed over ``[k/fps - T/2, k/fps + T/2]``; the truth for frame ``k`` is the ball centre at
mid-exposure, ``t = k / fps``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

GRAVITY = 9.81


@dataclass(frozen=True, kw_only=True)
class Bounce:
    """A ballistic bounce in the plane frame (SI units, angles in degrees from the normal)."""

    speed_in: float = 2.0
    angle_in: float = 40.0
    normal_ratio: float = 0.7      # -v_y(out) / v_y(in)
    tangential_ratio: float = 0.85  # v_x(out) / v_x(in)
    t_contact: float = 0.050       # s after frame 0
    x_contact: float = 0.120       # m along the plane from the scene's surface point

    def velocity_in(self) -> np.ndarray:
        a = math.radians(self.angle_in)
        return np.array([self.speed_in * math.sin(a), -self.speed_in * math.cos(a)])

    def velocity_out(self) -> np.ndarray:
        vx, vy = self.velocity_in()
        return np.array([self.tangential_ratio * vx, -self.normal_ratio * vy])

    def rebound_speed(self) -> float:
        return float(np.hypot(*self.velocity_out()))

    def rebound_angle(self) -> float:
        vx, vy = self.velocity_out()
        return math.degrees(math.atan2(vx, vy))

    def incidence_speed(self) -> float:
        return self.speed_in


@dataclass(frozen=True, kw_only=True)
class Scene:
    """Camera, lighting and clutter. Pixel coordinates: origin top-left, ``v`` down."""

    width: int = 320
    height: int = 240
    fps: float = 1000.0
    n_frames: int = 100
    ball_diameter: float = 0.0256          # m (the paper's ball)
    radius_px: float = 12.0                 # sets the scale: metres_per_px = diameter / (2 r)
    inclination: float = 15.0               # deg; the ball travels down-slope to the right
    surface_point: tuple[float, float] = (0.0, 150.0)  # px, a point of the surface line
    ball_centre_grey: float = 235.0
    ball_rim_grey: float = 160.0
    background_grey: float = 85.0
    texture_sigma: float = 18.0
    plane_grey: float = 55.0
    exposure: float = 0.0                   # fraction of the frame interval; 0 = no blur
    noise_sigma: float = 0.0
    shadow: bool = False
    flicker: float = 0.0                    # relative amplitude of 100 Hz lamp flicker
    seed: int = 0

    @property
    def metres_per_px(self) -> float:
        return self.ball_diameter / (2.0 * self.radius_px)

    @property
    def radius_m(self) -> float:
        return self.ball_diameter / 2.0

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors in the image of the plane frame's ``x`` (travel) and ``y`` (normal)."""
        b = math.radians(self.inclination)
        return np.array([math.cos(b), math.sin(b)]), np.array([math.sin(b), -math.cos(b)])

    def surface_points(self, length: float = 300.0) -> tuple[float, float, float, float]:
        """Two points (px) on the surface line, as ``--surface`` takes them."""
        e, _ = self.axes()
        u0, v0 = self.surface_point
        return (u0, v0, u0 + length * e[0], v0 + length * e[1])

    def gravity(self) -> np.ndarray:
        b = math.radians(self.inclination)
        return np.array([GRAVITY * math.sin(b), -GRAVITY * math.cos(b)])


def plane_positions(scene: Scene, bounce: Bounce, t: np.ndarray) -> np.ndarray:
    """Ball centre (m) in the plane frame at times ``t`` (s), shape ``t.shape + (2,)``."""
    t = np.asarray(t, dtype=float)[..., None]
    dt = t - bounce.t_contact
    v = np.where(dt < 0, bounce.velocity_in(), bounce.velocity_out())
    start = np.array([bounce.x_contact, scene.radius_m])
    return start + v * dt + 0.5 * scene.gravity() * dt**2


def to_pixels(scene: Scene, xy: np.ndarray) -> np.ndarray:
    """Plane-frame metres to image pixels ``(u, v)``."""
    e, n = scene.axes()
    uv = (xy[..., :1] * e + xy[..., 1:] * n) / scene.metres_per_px
    return uv + np.asarray(scene.surface_point)


def true_centres(scene: Scene, bounce: Bounce) -> np.ndarray:
    """Mid-exposure ball centre (px) of every frame, shape ``(n_frames, 2)``."""
    t = np.arange(scene.n_frames) / scene.fps
    return to_pixels(scene, plane_positions(scene, bounce, t))


def background(scene: Scene) -> np.ndarray:
    """The static scene (float grey levels): textured wall, plane with stripes, edge highlight."""
    rng = np.random.default_rng(scene.seed)
    h, w = scene.height, scene.width
    tex = np.zeros((h, w), np.float32)
    for sigma, weight in ((1.5, 0.6), (6.0, 1.0)):
        layer = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), sigma)
        tex += weight * layer / layer.std()
    wall = scene.background_grey + scene.texture_sigma * tex / tex.std()
    e, n = scene.axes()
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float32)
    du, dv = uu - scene.surface_point[0], vv - scene.surface_point[1]
    height = du * n[0] + dv * n[1]          # signed distance to the surface line, + outward
    along = du * e[0] + dv * e[1]
    stripes = 8.0 * np.sin(2 * np.pi * (height / 5.0 + 0.3 * np.sin(along / 40.0)))
    plane = scene.plane_grey + stripes + 6.0 * tex
    cover = np.clip(0.5 - height, 0.0, 1.0)
    img = wall * (1 - cover) + plane * cover + 70.0 * np.exp(-0.5 * (height / 0.8) ** 2)
    return img.astype(np.float32)


def _ball_layer(scene: Scene, centres: np.ndarray, box: tuple[int, int, int, int]):
    """Mean coverage and mean coverage*shade over the sub-frame ``centres``, inside ``box``."""
    u0, v0, u1, v1 = box
    vv, uu = np.mgrid[v0:v1, u0:u1].astype(np.float64)
    r = scene.radius_px
    cover = np.zeros(uu.shape)
    paint = np.zeros(uu.shape)
    for cu, cv in centres:
        d = np.hypot(uu - cu, vv - cv)
        c = np.clip(r + 0.5 - d, 0.0, 1.0)
        q = np.clip(d / r, 0.0, 1.0)
        shade = scene.ball_rim_grey + (scene.ball_centre_grey - scene.ball_rim_grey) * np.sqrt(
            1.0 - q**2)
        cover += c
        paint += c * shade
    return cover / len(centres), paint / len(centres)


def _shadow(scene: Scene, centre: np.ndarray, h: int, w: int) -> np.ndarray:
    """Multiplicative darkening of a soft disk offset down-right of the ball."""
    r = scene.radius_px
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float32)
    d = np.hypot(uu - (centre[0] + 0.9 * r), vv - (centre[1] + 0.6 * r))
    inside = 0.5 - 0.5 * np.tanh((d - 1.1 * r) / 4.0)  # logistic edge, 2 px scale
    return 1.0 - 0.45 * inside


def render(scene: Scene, bounce: Bounce) -> np.ndarray:
    """All frames, ``(n_frames, height, width)`` uint8."""
    rng = np.random.default_rng(scene.seed + 1)
    base = background(scene)
    h, w = base.shape
    n_sub = 1 if scene.exposure == 0 else 9
    offsets = ((np.arange(n_sub) + 0.5) / n_sub - 0.5) * scene.exposure / scene.fps
    frames = np.empty((scene.n_frames, h, w), np.uint8)
    pad = int(scene.radius_px) + 3
    for k in range(scene.n_frames):
        t = k / scene.fps + offsets
        centres = to_pixels(scene, plane_positions(scene, bounce, t))
        img = base.copy()
        if scene.shadow:
            img *= _shadow(scene, centres[n_sub // 2], h, w)
        lo = np.floor(centres.min(axis=0)).astype(int) - pad
        hi = np.ceil(centres.max(axis=0)).astype(int) + pad
        box = (max(lo[0], 0), max(lo[1], 0), min(hi[0], w), min(hi[1], h))
        if box[2] > box[0] and box[3] > box[1]:
            cover, paint = _ball_layer(scene, centres, box)
            sub = img[box[1]:box[3], box[0]:box[2]]
            img[box[1]:box[3], box[0]:box[2]] = sub * (1 - cover) + paint
        if scene.flicker:
            img *= 1.0 + scene.flicker * math.sin(2 * math.pi * 100.0 * k / scene.fps)
        if scene.noise_sigma:
            img += rng.normal(0.0, scene.noise_sigma, img.shape).astype(np.float32)
        frames[k] = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    return frames


def write_png_sequence(frames: np.ndarray, folder: Path, *, pad: bool = False) -> Path:
    """``folder/frame_<k>.png``; unpadded indices by default, to exercise natural sorting."""
    folder.mkdir(parents=True, exist_ok=True)
    for k, frame in enumerate(frames):
        name = f"frame_{k:04d}.png" if pad else f"frame_{k}.png"
        assert cv2.imwrite(str(folder / name), frame)
    return folder


def write_video(frames: np.ndarray, path: Path, fps: float, fourcc: str = "FFV1") -> Path:
    """Write a grey video; FFV1 (lossless) in .avi/.mkv, MJPG or mp4v for lossy files."""
    h, w = frames.shape[1:]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (w, h),
                             isColor=False)
    assert writer.isOpened(), f"cannot write {path} with {fourcc}"
    for frame in frames:
        writer.write(frame)
    writer.release()
    return path
