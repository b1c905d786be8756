"""Environment images for ``lights.N.kind = environment`` (issue 32): a built-in name
(physics.environment.BUILTIN_ENVIRONMENTS) or an HDR file — Radiance ``.hdr``/``.pic`` decoded with
imagecodecs (imageio reads Radiance files only through the FreeImage or OpenCV binaries, which are
not installed) and OpenEXR ``.exr`` with the ``openexr`` package — in an equirectangular (2:1) or
cube-cross (horizontal 4:3, vertical 3:4) layout, returned as a validated linear equirect.

A file that is not HDR (8-bit PNG/JPEG), holds NaN/Inf or negative texels, is smaller than 8 texels
or wider than MAX_WIDTH, or whose aspect fits no layout is refused with one line (EnvironmentMapError);
the caller keeps its last good environment.

Cube cross, as seen from the head: the middle face of the row of four is the panorama's centre
(-z), to its left the viewer's left, to its right the viewer's right (+x), then the back; the up face
sits above the centre face (its bottom edge touching it), the down face below it. The vertical cross
puts the back face under the down face, upside down.
"""
from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from skinviewer.ground.files import FileReadError, read_regular_file
from skinviewer.physics.environment import (
    BUILTIN_ENVIRONMENTS,
    builtin_environment,
    equirect_directions,
)

MAX_BYTES = 1024**3
MAX_WIDTH = 16384    # a 16k panorama is the largest published; 32768 wide is refused
MIN_WIDTH = 8
HDR_SUFFIXES = (".hdr", ".pic", ".rgbe")
LAYOUTS = ("auto", "equirect", "cross")
EQUIRECT_SIZE = (512, 256)  # a cross is resampled to this equirect


class EnvironmentMapError(OSError):
    """An environment that cannot be used, with one line saying why (an OSError: the command line
    reports it as one line with exit status 2, like any unreadable input file)."""


def _hdr_size(path: str, data: bytes) -> tuple[int, int]:
    """(w, h) from a Radiance header's resolution line ("-Y h +X w"), read before any decoding."""
    head = data[:4096]
    end = head.find(b"\n\n")
    if end < 0:
        raise EnvironmentMapError(f"environment {path}: not a Radiance HDR file (no header end)")
    line = head[end + 2:].split(b"\n", 1)[0].split()
    try:
        dims = {line[0][1:]: int(line[1]), line[2][1:]: int(line[3])}
        return dims[b"X"], dims[b"Y"]
    except (IndexError, ValueError, KeyError):
        raise EnvironmentMapError(f"environment {path}: unreadable Radiance resolution line") from None


def _check_size(path: str, w: int, h: int) -> None:
    if w < MIN_WIDTH or h < MIN_WIDTH // 2:
        raise EnvironmentMapError(f"environment {path}: {w}x{h} is too small (at least {MIN_WIDTH}x{MIN_WIDTH // 2})")
    if w > MAX_WIDTH or h > MAX_WIDTH:
        raise EnvironmentMapError(f"environment {path}: {w}x{h} is larger than {MAX_WIDTH} texels on a side; "
                                  "downsample it first")


def _decode(path: str, data: bytes) -> np.ndarray:
    suffix = Path(path).suffix.lower()
    if suffix in HDR_SUFFIXES or data[:2] == b"#?":
        _check_size(path, *_hdr_size(path, data))
        import imagecodecs
        try:
            return np.asarray(imagecodecs.rgbe_decode(data), np.float32)
        except Exception as exc:  # noqa: BLE001  (imagecodecs raises its own RgbeError, ValueError, ...)
            raise EnvironmentMapError(f"environment {path}: not a readable Radiance HDR file ({exc})") from None
    if suffix == ".exr" or data[:4] == b"\x76\x2f\x31\x01":
        import OpenEXR
        try:
            with OpenEXR.File(path, header_only=True) as f:
                box = f.header().get("dataWindow")
            if box is not None:
                lo, hi = np.asarray(box[0]), np.asarray(box[1])
                _check_size(path, int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1))
            with OpenEXR.File(path) as f:
                ch = f.channels()
                key = next((k for k in ("RGBA", "RGB", "Y") if k in ch), None)
                if key is None:
                    if all(k in ch for k in "RGB"):
                        return np.stack([np.asarray(ch[k].pixels, np.float32) for k in "RGB"], -1)
                    raise EnvironmentMapError(f"environment {path}: no RGB, RGBA or Y channels (has {', '.join(ch)})")
                return np.asarray(ch[key].pixels, np.float32)
        except EnvironmentMapError:
            raise
        except Exception as exc:  # noqa: BLE001  (the OpenEXR binding raises plain Exceptions)
            raise EnvironmentMapError(f"environment {path}: not a readable OpenEXR file ({exc})") from None
    raise EnvironmentMapError(f"environment {path}: not an HDR image (use a Radiance .hdr or an OpenEXR .exr of linear "
                           "radiance; an 8-bit PNG/JPEG clips the bright sources that light the skin)")


def _check(path: str, img: np.ndarray, layout: str) -> tuple[np.ndarray, str]:
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3 or img.shape[2] < 1:
        raise EnvironmentMapError(f"environment {path}: unexpected pixel shape {img.shape}")
    img = img[..., :3] if img.shape[2] >= 3 else np.repeat(img[..., :1], 3, axis=2)
    h, w = img.shape[:2]
    if w < MIN_WIDTH or h < MIN_WIDTH // 2:
        raise EnvironmentMapError(f"environment {path}: {w}x{h} is too small (at least {MIN_WIDTH}x{MIN_WIDTH // 2})")
    if w > MAX_WIDTH or h > MAX_WIDTH:
        raise EnvironmentMapError(f"environment {path}: {w}x{h} is larger than {MAX_WIDTH} texels on a side; "
                               "downsample it first")
    bad = ~np.isfinite(img)
    if bad.any():
        raise EnvironmentMapError(f"environment {path}: {int(bad.any(2).sum())} texels are NaN or Inf")
    neg = img < 0
    if neg.any():
        raise EnvironmentMapError(f"environment {path}: {int(neg.any(2).sum())} texels are negative (radiance is >= 0)")
    if layout == "auto":
        if abs(w - 2 * h) <= 1:
            layout = "equirect"
        elif 3 * w == 4 * h or 4 * w == 3 * h:
            layout = "cross"
        else:
            raise EnvironmentMapError(f"environment {path}: a {w}x{h} image is neither an equirect (2:1) nor a cube "
                                   "cross (4:3 or 3:4)")
    if layout == "equirect" and abs(w - 2 * h) > 1:
        raise EnvironmentMapError(f"environment {path}: an equirect must be twice as wide as high, not {w}x{h}")
    if layout == "cross" and not (3 * w == 4 * h or 4 * w == 3 * h):
        raise EnvironmentMapError(f"environment {path}: a cube cross must be 4:3 or 3:4 with square faces, not {w}x{h}")
    return np.ascontiguousarray(img, np.float32), layout


def cross_to_equirect(cross: np.ndarray, size: tuple[int, int] = EQUIRECT_SIZE) -> np.ndarray:
    """Resample a cube cross (see the module doc) to an equirect (H, W, 3), nearest texel of the face."""
    ch, cw = cross.shape[:2]
    vertical = ch > cw
    face = cw // 3 if vertical else cw // 4
    w, h = size
    d = equirect_directions(w, h).reshape(-1, 3)
    r, u, f = d[:, 0], d[:, 1], -d[:, 2]  # right, up, forward (the panorama's centre)
    a = np.abs(np.stack([r, u, f], 1))
    k = a.argmax(1)
    s = np.zeros(len(d))
    t = np.zeros(len(d))
    col = np.zeros(len(d), np.int64)
    row = np.zeros(len(d), np.int64)
    flip = np.zeros(len(d), bool)

    def put(mask, ss, tt, c, rr, fl=False):
        s[mask], t[mask], col[mask], row[mask], flip[mask] = ss[mask], tt[mask], c, rr, fl
    with np.errstate(divide="ignore", invalid="ignore"):
        put((k == 2) & (f > 0), r / f, u / f, 1, 1)                          # front
        put((k == 2) & (f <= 0), r / f, u / -f, 1 if vertical else 3, 3 if vertical else 1, vertical)  # back
        put((k == 0) & (r > 0), -f / r, u / r, 2, 1)                         # right
        put((k == 0) & (r <= 0), f / -r, u / -r, 0, 1)                       # left
        put((k == 1) & (u > 0), r / u, -f / u, 1, 0)                         # up
        put((k == 1) & (u <= 0), r / -u, f / -u, 1, 2)                       # down
    s = np.where(flip, -s, s)
    t = np.where(flip, -t, t)
    x = np.clip(((s + 1) * 0.5 * face).astype(np.int64), 0, face - 1) + col * face
    y = np.clip(((1 - t) * 0.5 * face).astype(np.int64), 0, face - 1) + row * face
    return np.ascontiguousarray(cross[y, x].reshape(h, w, -1), np.float32)


def load_environment_file(path: str | os.PathLike, layout: str = "auto") -> np.ndarray:
    """The linear equirect (H, W, 3) float32 of an HDR file (module doc); EnvironmentMapError if unusable."""
    p = os.fspath(path)
    try:
        data = read_regular_file(p, MAX_BYTES, what=f"environment {p}")
    except FileReadError as exc:
        raise EnvironmentMapError(str(exc)) from None
    img, lay = _check(p, _decode(p, data), layout)
    return cross_to_equirect(img) if lay == "cross" else img


@functools.lru_cache(maxsize=4)
def _cached(spec: str, layout: str, stamp: tuple) -> np.ndarray:
    img = builtin_environment(spec) if spec in BUILTIN_ENVIRONMENTS else load_environment_file(spec, layout)
    img.setflags(write=False)
    return img


def environment_image(spec: str, layout: str = "auto", base: str | os.PathLike | None = None) -> np.ndarray:
    """The equirect of ``spec``: a built-in name or a file path (relative paths from ``base``), cached
    by path, size and modification time."""
    if spec in BUILTIN_ENVIRONMENTS:
        return _cached(spec, "equirect", ())
    p = Path(spec)
    if base is not None and not p.is_absolute():
        p = Path(base) / p
    try:
        st = p.stat()
        stamp = (st.st_size, st.st_mtime_ns)
    except OSError as exc:
        raise EnvironmentMapError(f"cannot read environment {spec}: {exc.strerror or exc} (built-ins: "
                               f"{', '.join(BUILTIN_ENVIRONMENTS)})") from None
    return _cached(str(p), layout, stamp)


def environment_problems(settings) -> list[tuple[str, str]]:
    """(path, message) for each environment light whose image cannot be used (the viewer refuses
    such an edit and keeps the last good environment; the renderer raises the first)."""
    out = []
    for i, light in enumerate(settings.lights):
        if light.kind != "environment":
            continue
        try:
            environment_image(light.environment, light.layout)
        except EnvironmentMapError as exc:
            out.append((f"lights.{i}.environment", str(exc)))
    return out
