"""An independent renderer of high-speed bounce videos, for the tracker's accuracy checks.

Written apart from ``tests/video_helpers.py`` and from ``bouncebayes.tracking`` (no code shared):
the ball is a sphere shaded with physically based terms, the optics and sensor are simulated
explicitly, so that the tracker's edge model is tested on images it was not built from.

- **Ball**: a sphere of radius ``R`` (pixels) seen orthographically. Surface normal at image
  offset ``q = (p - c) / R``: ``n = (q_u, -q_v, sqrt(1 - |q|^2))`` (camera frame: x right, y up,
  z to the camera). Radiance = ``albedo * (ambient + lambert * limb)`` + ``specular``, with
  ``lambert = max(0, n . l)`` (light direction ``l``), a linear limb-darkening law
  ``limb = 1 - u (1 - n_z)``, and a Blinn-Phong lobe ``k_s max(0, n . h)^shininess``,
  ``h = (l + z) / |l + z|``. Optionally (``mark``) a dark stripe painted on it, as
  experimenters mark a ball to see it turn: a great circle through the axis towards the
  camera, the albedo 80 % lower where ``|n . p| < mark / 2`` (``p`` its normal in the image
  plane), turning at ``spin`` rad/s; or (``spot``) a dark spot, a logo, of angular radius
  ``spot`` whose centre lies ``spot_tilt`` from that axis, turning alike.
- **Anti-aliasing**: every pixel is integrated on an ``S x S`` sub-grid (default 6), each
  sub-sample's coverage a linear ramp one sub-pixel wide (exact area to well below 0.01 px).
- **Exposure**: the frame integrates the scene over ``exposure / fps`` seconds centred on
  ``k / fps``: ``n_sub`` ball positions along the true parabolic path are averaged (motion blur).
  A rolling shutter (``readout`` > 0, seconds) reads row ``j`` of ``height`` centred on
  ``k / fps + readout j / height`` instead (the window around the ball rendered at each row's
  time, that row kept).
- **Lens**: a point-spread function whose SD per axis is ``sigma_px`` pixels, applied to the
  super-sampled image before pixel integration: a Gaussian (``psf="gaussian"``), or a lens out
  of focus, a uniform disk of radius ``2 sigma_px`` (``psf="disk"``, sampled 8 x 8 per
  super-sampled pixel).
- **Background**: a continuous textured wall (sum of random-phase plane waves), the surface
  line with a darker plane below it; optional lit band above the surface, a static occluder
  (a vertical post in front of the ball), a contact shadow under the ball, the ball's shadow
  cast on the wall by a lamp (``cast``: an offset disk, its penumbra 0.3 radii wide), a glossy
  surface (``reflect``: the ball's mirror image below the surface line, its radiance times
  the reflectance added to the plane's).
- **Camera motion** (``camera``, one ``(du, dv)`` or ``(du, dv, turn, zoom)`` per frame):
  frame ``k`` shows the scene point ``p + d_k`` at pixel ``p``, or with a turn (degrees) and
  zoom (a fraction) ``c + (1 + zoom) R(turn) (p - c) + d_k``, ``c`` the frame's centre (the
  whole scene rendered again at those points; ``true_centres`` stay in the scene's pixels).
- **The ball towards the camera** (``approach``, 1/s): its picture (radius and offset from the
  frame's centre) ``1 / (1 - approach t)`` times its size at ``t = 0``, as a pinhole camera
  sees a ball coming closer at a steady speed (the wall and surface stay where they are).
- **Sensor**: gain to grey levels, shot noise (variance ``shot * grey``) plus read noise,
  clipping at 0 and 255 (a saturated highlight), optionally the camera's tone curve (``tone``:
  ``"srgb"``, IEC 61966-2-1's encoding, or ``"rec709"``, the BT.709 camera curve, applied to the
  clipped signal over 255), 8-bit rounding; then optionally a lossy codec
  (``"MJPG"`` in .avi or ``"mp4v"`` in .mp4 through OpenCV) and decoding back.

The truth: ``Shot.true_centres()`` (mid-exposure centres, px), ``Shot.radius_px`` and the
plane-frame bounce velocities of :class:`Throw`.
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

G = 9.81


@dataclass(frozen=True, kw_only=True)
class Throw:
    """A bounce in the plane frame (x along the surface in the direction of travel, y the
    outward normal; metres, seconds). ``angle_in`` is from the normal, degrees."""

    speed_in: float = 2.0
    angle_in: float = 35.0
    e_n: float = 0.65                 # -vy_out / vy_in
    e_t: float = 0.8                  # vx_out / vx_in
    t_contact: float = 0.040
    x_contact: float = 0.10

    def v_in(self) -> np.ndarray:
        a = math.radians(self.angle_in)
        return np.array([self.speed_in * math.sin(a), -self.speed_in * math.cos(a)])

    def v_out(self) -> np.ndarray:
        vx, vy = self.v_in()
        return np.array([self.e_t * vx, -self.e_n * vy])

    def rebound_speed(self) -> float:
        return float(np.hypot(*self.v_out()))

    def rebound_angle(self) -> float:
        vx, vy = self.v_out()
        return math.degrees(math.atan2(vx, vy))


@dataclass(frozen=True, kw_only=True)
class Shot:
    """Camera, optics, lighting and scene of one rendered video."""

    width: int = 160
    height: int = 96
    fps: float = 1000.0
    n_frames: int = 60
    diameter_m: float = 0.0256
    radius_px: float = 10.0
    slope_deg: float = 8.0            # surface inclination in the image (down to the right)
    surface_v: float = 60.0           # image row of the surface line at u = 0
    # optics and exposure
    sigma_px: float = 0.0
    psf: str = "gaussian"             # or "disk": out of focus (radius 2 sigma_px)
    exposure: float = 0.0             # fraction of the frame interval
    readout: float = 0.0              # rolling shutter: s from the top row's read to the bottom's
    supersample: int = 6
    # lighting (camera frame: x right, y up, z to the camera)
    light: tuple[float, float, float] = (-0.4, 0.5, 0.77)
    albedo: float = 0.85
    ambient: float = 0.4
    limb_u: float = 0.3
    specular: float = 0.0             # Blinn-Phong strength (0: matte)
    mark: float = 0.0                 # width (in n) of a dark stripe painted on the ball (0: none)
    spot: float = 0.0                 # angular radius (rad) of a dark spot (a logo; 0: none) ...
    spot_tilt: float = 1.2            # ... its centre this far (rad) from the axis to the camera
    spin: float = 150.0               # rad/s: the stripe's (or spot's) turn about the axis to
    #                                   the camera
    shininess: float = 40.0
    gain: float = 230.0               # grey level of radiance 1
    # background (grey levels)
    wall: float = 50.0
    texture: float = 10.0
    plane: float = 30.0
    band: float = 0.0                 # extra grey of a lit band just above the surface
    occluder_u: float | None = None   # column of a static post in front of the ball
    shadow: float = 0.0               # depth (0-1) of a soft contact shadow under the ball
    reflect: float = 0.0              # reflectance of a glossy surface: the ball's mirror image
    camera: tuple[tuple[float, ...], ...] | None = None  # per frame: the camera's shift (px)
    #                                   and optionally its turn (degrees) and zoom (fraction)
    cast: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the ball's shadow on the wall: its
    #                                   offset from the ball (u, v, in radii) and depth (0-1)
    # sensor and codec
    read_noise: float = 1.5
    shot: float = 0.05
    codec: str | None = None          # "MJPG" or "mp4v"
    tone: str = "linear"              # the camera's tone curve: "linear", "srgb" or "rec709"
    seed: int = 0
    throw: Throw = field(default_factory=Throw)
    # 1/s: the ball's speed towards the camera as a fraction of its distance at t = 0 (its
    # picture, radius and offset from the frame's centre, then 1 / (1 - approach t) times)
    approach: float = 0.0

    @property
    def metres_per_px(self) -> float:
        return self.diameter_m / (2.0 * self.radius_px)

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        b = math.radians(self.slope_deg)
        e = np.array([math.cos(b), math.sin(b)])
        return e, np.array([e[1], -e[0]])

    def surface_points(self) -> tuple[float, float, float, float]:
        e, _ = self.axes()
        return (0.0, self.surface_v, 100.0 * e[0], self.surface_v + 100.0 * e[1])

    def plane_xy(self, t: np.ndarray) -> np.ndarray:
        """Ball centre in the plane frame (m) at times ``t``."""
        th = self.throw
        b = math.radians(self.slope_deg)
        g = np.array([G * math.sin(b), -G * math.cos(b)])
        dt = np.asarray(t, dtype=float)[..., None] - th.t_contact
        v = np.where(dt < 0, th.v_in(), th.v_out())
        return np.array([th.x_contact, self.diameter_m / 2]) + v * dt + 0.5 * g * dt * dt

    def pixels(self, xy: np.ndarray) -> np.ndarray:
        e, n = self.axes()
        uv = (xy[..., :1] * e + xy[..., 1:] * n) / self.metres_per_px
        return uv + np.array([0.0, self.surface_v])

    def depth_scale(self, t: np.ndarray) -> np.ndarray:
        """How much larger the ball's picture is at times ``t`` than at 0 (``approach``)."""
        return 1.0 / (1.0 - self.approach * np.asarray(t, dtype=float))

    def image(self, t: np.ndarray) -> np.ndarray:
        """The ball's centre in the image (px) at times ``t``: :meth:`pixels` of
        :meth:`plane_xy`, scaled about the frame's centre where the ball ``approach``es."""
        c = self.pixels(self.plane_xy(t))
        if not self.approach:
            return c
        mid = np.array([(self.width - 1) / 2.0, (self.height - 1) / 2.0])
        return mid + self.depth_scale(t)[..., None] * (c - mid)

    def true_centres(self) -> np.ndarray:
        """Frame ``k``'s ball centre (px) at ``k / fps``; with a rolling shutter, where the ball
        was when the row through that centre was read (``k / fps + readout v / height``, by
        fixed-point iteration: the row moves by less than 0.01 px a step)."""
        t = np.arange(self.n_frames) / self.fps
        c = self.image(t)
        for _ in range(6 if self.readout > 0 else 0):
            c = self.image(t + self.readout * c[:, 1] / self.height)
        return c


def _wall(shot: Shot, u: np.ndarray, v: np.ndarray, rng_seed: int) -> np.ndarray:
    """Continuous background radiance (grey levels) at image points ``(u, v)``."""
    rng = np.random.default_rng(rng_seed)
    k = rng.uniform(0.05, 0.6, 12) * rng.choice([-1, 1], 12)
    ang = rng.uniform(0, np.pi, 12)
    ph = rng.uniform(0, 2 * np.pi, 12)
    tex = sum(np.sin(ki * (np.cos(a) * u + np.sin(a) * v) + p) for ki, a, p in zip(k, ang, ph, strict=True))
    e, n = shot.axes()
    height = u * n[0] + (v - shot.surface_v) * n[1]   # + above the surface
    wall = shot.wall + shot.texture * tex / math.sqrt(6.0)
    wall = wall + shot.band * np.exp(-0.5 * ((height - 4.0) / 3.0) ** 2)
    below = np.clip(0.5 - height, 0.0, 1.0)
    img = wall * (1 - below) + (shot.plane + 0.3 * shot.texture * np.sin(0.7 * u)) * below
    return img


def _ball(shot: Shot, du: np.ndarray, dv: np.ndarray, sub: float, t: float = 0.0
          ) -> tuple[np.ndarray, ...]:
    """Coverage and radiance (grey levels) of the ball at offsets ``(du, dv)`` from its centre
    at time ``t`` (s: the painted stripe's angle)."""
    r = shot.radius_px
    d = np.hypot(du, dv)
    cover = np.clip((r - d) / sub + 0.5, 0.0, 1.0)
    q2 = np.minimum((du * du + dv * dv) / (r * r), 1.0)
    nz = np.sqrt(1.0 - q2)
    nx, ny = du / r, -dv / r
    lx, ly, lz = np.asarray(shot.light) / np.linalg.norm(shot.light)
    lam = np.maximum(0.0, nx * lx + ny * ly + nz * lz)
    limb = 1.0 - shot.limb_u * (1.0 - nz)
    hx, hy, hz = lx, ly, lz + 1.0
    hn = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-12)
    spec = shot.specular * np.maximum(0.0, (nx * hx + ny * hy + nz * hz) / hn) ** shot.shininess
    albedo = shot.albedo
    if shot.mark > 0:  # a great circle through the spin axis (towards the camera), turning
        phi = 0.6 + shot.spin * t
        off = np.abs(-math.sin(phi) * nx + math.cos(phi) * ny)
        albedo = albedo * (1.0 - 0.8 * np.clip((0.5 * shot.mark - off) / 0.05 + 0.5, 0.0, 1.0))
    if shot.spot > 0:  # a dark spot near the rim, turning with the ball about the same axis
        phi, tilt = 0.6 + shot.spin * t, shot.spot_tilt
        cos_off = (math.sin(tilt) * (math.cos(phi) * nx + math.sin(phi) * ny)
                   + math.cos(tilt) * nz)
        off = np.arccos(np.clip(cos_off, -1.0, 1.0))
        albedo = albedo * (1.0 - 0.8 * np.clip((shot.spot - off) / 0.05 + 0.5, 0.0, 1.0))
    radiance = albedo * (shot.ambient + lam * limb) + spec
    return cover, shot.gain * radiance


def render(shot: Shot) -> np.ndarray:
    """All frames ``(n_frames, height, width)`` uint8, after the codec if one is set."""
    s = shot.supersample
    h, w = shot.height, shot.width
    sub = 1.0 / s
    offs = (np.arange(s) + 0.5) / s - 0.5
    uu = (np.arange(w)[:, None] + offs[None, :]).ravel()
    vv = (np.arange(h)[:, None] + offs[None, :]).ravel()
    U, V = np.meshgrid(uu, vv)
    wall_hi = _wall(shot, U, V, shot.seed)
    if shot.occluder_u is not None:
        post = np.clip(3.0 - np.abs(U - shot.occluder_u), 0.0, 1.0)
        wall_hi = wall_hi * (1 - post) + 30.0 * post
    else:
        post = None
    sig = shot.sigma_px * s
    if shot.psf not in ("gaussian", "disk"):
        raise ValueError(f"psf must be 'gaussian' or 'disk'; got {shot.psf!r}")
    if sig > 0 and shot.psf == "disk":
        kernel = _disk_kernel(2.0 * sig)
        blur = (lambda a: cv2.filter2D(a, -1, kernel, borderType=cv2.BORDER_REFLECT))
    elif sig > 0:
        blur = (lambda a: cv2.GaussianBlur(a, (0, 0), sig, borderType=cv2.BORDER_REFLECT))
    else:
        blur = (lambda a: a)

    def down(a: np.ndarray) -> np.ndarray:
        return a.reshape(a.shape[0] // s, s, a.shape[1] // s, s).mean(axis=(1, 3))

    n_sub = 1 if shot.exposure == 0 else 16
    offsets = ((np.arange(n_sub) + 0.5) / n_sub - 0.5) * shot.exposure / shot.fps
    rng = np.random.default_rng(shot.seed + 7)
    margin = int(math.ceil(4 * shot.sigma_px)) + 3
    frames = np.empty((shot.n_frames, h, w), np.uint8)
    base = down(blur(wall_hi.astype(np.float32)))
    scene = {"wall": wall_hi, "post": post, "d": np.zeros(2), "map": None}

    def window(cs: np.ndarray, sl, ts: np.ndarray) -> np.ndarray:
        """The window ``sl`` (super-sampled slices) with the ball at the positions ``cs``
        (times ``ts``) averaged (the exposure), blurred and integrated over pixels."""
        if scene["map"] is not None:  # a turned or zoomed camera: the scene's points
            Uw, Vw = scene["map"][0][sl], scene["map"][1][sl]
        else:
            Uw, Vw = U[sl] + scene["d"][0], V[sl] + scene["d"][1]
        bw = scene["wall"][sl]
        post = scene["post"]
        acc = np.zeros(Uw.shape)
        for (cu, cv), t in zip(cs, ts, strict=True):
            bw_k = bw * _shadow(shot, Uw, Vw, cu, cv) if shot.shadow > 0 else bw
            if shot.cast[2] > 0:  # a lamp casts the ball's shadow on the wall behind it
                r = shot.radius_px
                d = np.hypot(Uw - cu - shot.cast[0] * r, Vw - cv - shot.cast[1] * r) / r
                bw_k = bw_k * (1.0 - shot.cast[2] * np.clip((1.15 - d) / 0.3, 0.0, 1.0))
            near = shot if not shot.approach else dataclasses.replace(
                shot, radius_px=shot.radius_px * float(shot.depth_scale(t)))
            cover, rad = _ball(near, Uw - cu, Vw - cv, sub, t)
            comp = bw_k * (1 - cover) + rad * cover
            if shot.reflect > 0:  # the ball mirrored in the surface, seen below it
                e, n = shot.axes()
                hw = Uw * n[0] + (Vw - shot.surface_v) * n[1]
                mc, mr = _ball(shot, Uw - 2 * hw * n[0] - cu, Vw - 2 * hw * n[1] - cv, sub, t)
                comp = comp + shot.reflect * mr * mc * np.clip(0.5 - hw, 0.0, 1.0)
            if post is not None:
                pw = post[sl]
                comp = comp * (1 - pw) + 30.0 * pw
            acc += comp
        return down(blur((acc / len(cs)).astype(np.float32)))

    for k in range(shot.n_frames):
        # a rolling shutter reads row j at k / fps + readout j / height: the window at every
        # row's time, that row kept
        late = shot.readout * np.arange(h) / h
        cs = shot.image(k / shot.fps + offsets[:, None] + late[[0, -1]]).reshape(-1, 2)
        cam = np.zeros(2) if shot.camera is None else np.asarray(shot.camera[k], float)
        shift = cam[:2]
        if cam.size == 4 and cam[2:].any():  # turned or zoomed: the scene at c + A (p - c) + d
            A, mid = _camera_matrix(cam), np.array([(w - 1) / 2.0, (h - 1) / 2.0])
            Us = mid[0] + A[0, 0] * (U - mid[0]) + A[0, 1] * (V - mid[1]) + shift[0]
            Vs = mid[1] + A[1, 0] * (U - mid[0]) + A[1, 1] * (V - mid[1]) + shift[1]
            wall_k = _wall(shot, Us, Vs, shot.seed)
            post_k = None
            if shot.occluder_u is not None:
                post_k = np.clip(3.0 - np.abs(Us - shot.occluder_u), 0.0, 1.0)
                wall_k = wall_k * (1 - post_k) + 30.0 * post_k
            scene.update(wall=wall_k, post=post_k, d=shift, map=(Us, Vs))
            img = down(blur(wall_k.astype(np.float32)))
            # the window's bounds in the image: the ball's scene points mapped back
            cs = mid + (cs - mid - shift) @ np.linalg.inv(A).T + shift
        elif shift.any():  # the scene at p + d: the wall drawn again, the ball at c - d
            wall_k = _wall(shot, U + shift[0], V + shift[1], shot.seed)
            post_k = None
            if shot.occluder_u is not None:
                post_k = np.clip(3.0 - np.abs(U + shift[0] - shot.occluder_u), 0.0, 1.0)
                wall_k = wall_k * (1 - post_k) + 30.0 * post_k
            scene.update(wall=wall_k, post=post_k, d=shift, map=None)
            img = down(blur(wall_k.astype(np.float32)))
        else:
            scene.update(wall=wall_hi, post=post, d=shift, map=None)
            img = base.copy()
        cs = cs - shift  # the window's bounds in the image
        # the window reaches two margins beyond the ball: the blur's halo (one margin) is
        # pasted, the outer margin only feeds the blur
        if shot.reflect > 0:  # the window holds the mirror image too
            e, n = shot.axes()
            hc = cs[:, 0] * n[0] + (cs[:, 1] - shot.surface_v) * n[1]
            cs = np.concatenate([cs, cs - 2 * hc[:, None] * n])
        r_k = shot.radius_px * float(np.max(shot.depth_scale(k / shot.fps + offsets)))
        lo = np.floor(cs.min(axis=0) - r_k).astype(int) - 2 * margin
        hi = np.ceil(cs.max(axis=0) + r_k).astype(int) + 2 * margin + 1
        u0, v0 = max(lo[0], 0), max(lo[1], 0)
        u1, v1 = min(hi[0], w), min(hi[1], h)
        if u1 > u0 and v1 > v0:
            sl = (slice(v0 * s, v1 * s), slice(u0 * s, u1 * s))
            if shot.readout > 0:
                win = np.empty((v1 - v0, u1 - u0))
                for j in range(v0, v1):
                    ts = k / shot.fps + offsets + late[j]
                    win[j - v0] = window(shot.image(ts), sl, ts)[j - v0]
            else:
                ts = k / shot.fps + offsets
                win = window(shot.image(ts), sl, ts)
            # the window's blur is exact away from its border: paste the inner part only
            iu0 = 0 if u0 == 0 else margin
            iv0 = 0 if v0 == 0 else margin
            iu1 = win.shape[1] - (0 if u1 == w else margin)
            iv1 = win.shape[0] - (0 if v1 == h else margin)
            img[v0 + iv0:v0 + iv1, u0 + iu0:u0 + iu1] = win[iv0:iv1, iu0:iu1]
        noisy = img + rng.standard_normal(img.shape) * np.sqrt(
            shot.read_noise**2 + shot.shot * np.maximum(img, 0.0))
        if shot.tone != "linear":
            noisy = 255.0 * _encode(np.clip(noisy, 0.0, 255.0) / 255.0, shot.tone)
        frames[k] = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
    return _codec(frames, shot) if shot.codec else frames


def _camera_matrix(cam: np.ndarray) -> np.ndarray:
    """``(1 + zoom) R(turn)`` of a camera entry ``(du, dv, turn_deg, zoom)``."""
    a = math.radians(float(cam[2]))
    return (1.0 + float(cam[3])) * np.array([[math.cos(a), -math.sin(a)],
                                             [math.sin(a), math.cos(a)]])


def _encode(x: np.ndarray, tone: str) -> np.ndarray:
    """Light ``x`` in [0, 1] to the stored signal in [0, 1] by the camera's tone curve."""
    if tone == "srgb":  # IEC 61966-2-1
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    if tone == "rec709":  # ITU-R BT.709 opto-electronic transfer
        return np.where(x < 0.018, 4.5 * x, 1.099 * np.power(x, 0.45) - 0.099)
    raise ValueError(f"unknown tone curve {tone!r}")


def _disk_kernel(radius: float, sub: int = 8) -> np.ndarray:
    """A uniform disk of ``radius`` (super-sampled pixels) as a normalised convolution kernel,
    each cell's coverage from ``sub x sub`` samples (float32)."""
    n = int(math.ceil(radius)) + 1
    y, x = np.mgrid[-n:n + 1, -n:n + 1].astype(float)
    offs = (np.arange(sub) + 0.5) / sub - 0.5
    k = sum(((x + dx) ** 2 + (y + dy) ** 2 <= radius * radius).astype(float)
            for dy in offs for dx in offs)
    return (k / k.sum()).astype(np.float32)


def _shadow(shot: Shot, U, V, cu, cv) -> np.ndarray:
    """Soft darkening on the surface below the ball, deeper as the ball comes closer."""
    e, n = shot.axes()
    height = (cu * n[0] + (cv - shot.surface_v) * n[1])  # ball centre above the surface (px)
    foot_u, foot_v = cu - height * n[0], cv - height * n[1]
    gap = max(height - shot.radius_px, 0.0)
    depth = shot.shadow * math.exp(-gap / (2 * shot.radius_px))
    d2 = ((U - foot_u) / (1.3 * shot.radius_px)) ** 2 + ((V - foot_v) / (0.5 * shot.radius_px)) ** 2
    return 1.0 - depth * np.exp(-d2)


def _codec(frames: np.ndarray, shot: Shot) -> np.ndarray:
    suffix = ".avi" if shot.codec == "MJPG" else ".mp4"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"v{suffix}"
        write(frames, path, shot.fps, shot.codec or "MJPG")
        cap = cv2.VideoCapture(str(path))
        out = []
        while True:
            ok, img = cap.read()
            if not ok:
                break
            out.append(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY))
        cap.release()
    return np.stack(out)


def burn_counter(frames: np.ndarray, x: int, baseline: int, right: bool = False) -> None:
    """A high-speed camera's frame counter burned into ``frames`` (in place): a black box and
    white digits (frame number, time at 1000 fps) that change every frame, the text's baseline
    at row ``baseline`` and its left edge at column ``x`` (its right edge, ``right``)."""
    for k, frame in enumerate(frames):
        text = f"{k:05d} {k / 1000:.3f}s"
        (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
        org = (x - tw if right else x, baseline)
        cv2.rectangle(frame, (org[0] - 2, org[1] - th - 2), (org[0] + tw + 2, org[1] + 3), 0, -1)
        cv2.putText(frame, text, org, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 255, 1, cv2.LINE_AA)


def write(frames: np.ndarray, path: Path, fps: float, fourcc: str) -> Path:
    """Frames to a video file (grey, through OpenCV's writer)."""
    h, w = frames.shape[1:]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (w, h),
                             isColor=False)
    if not writer.isOpened():
        raise OSError(f"cannot write {path} with {fourcc}")
    for f in frames:
        writer.write(f)
    writer.release()
    return path
