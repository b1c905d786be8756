"""Files are never half-written: every write goes to a temporary file in the target's folder and
is renamed over the target only when complete."""
from __future__ import annotations

import io
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np


def _read_umask() -> int:
    mask = os.umask(0)  # the only way to read it; done once, at import, before any thread starts
    os.umask(mask)
    return mask


_UMASK = _read_umask()


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ".tmp") -> Iterator[Path]:
    """Yields a temporary path beside ``path``; on success it replaces ``path``, on error it goes."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=suffix, dir=str(p.parent))
    os.close(fd)
    try:
        yield Path(tmp)
        # mkstemp creates the file 0600: give the result the mode a plain open() would (the target's
        # own mode when replacing it, else 0666 less the umask) so screenshots/presets are readable
        try:
            mode = p.stat().st_mode & 0o7777
        except FileNotFoundError:
            mode = 0o666 & ~_UMASK
        os.chmod(tmp, mode)
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def save_png(path: str | os.PathLike, img: np.ndarray) -> Path:
    """uint8 (H, W, 3|4) image, top row first."""
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(img)).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def save_npy(path: str | os.PathLike, arr: np.ndarray) -> Path:
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(arr, dtype=np.float32))
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def save_exr(path: str | os.PathLike, img: np.ndarray) -> Path:
    """Linear float image (H, W), (H, W, 1|3|4) as OpenEXR (float32, ZIP), top row first: what
    compositing and VFX tools read. Written to a temporary file and renamed like every writer."""
    import OpenEXR

    a = np.ascontiguousarray(np.nan_to_num(np.asarray(img, np.float32), nan=0.0, posinf=3e38, neginf=-3e38))
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[..., 0]
    if a.ndim == 2:
        channels = {"Y": a}
    elif a.shape[2] in (3, 4):
        channels = {"RGBA"[:a.shape[2]]: a}
    else:
        raise ValueError(f"save_exr: expected 1, 3 or 4 channels, got shape {a.shape}")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic_path(path, suffix=".exr") as tmp:
        with OpenEXR.File(header, channels) as f:
            f.write(str(tmp))
    return Path(path)


def load_exr(path: str | os.PathLike) -> np.ndarray:
    """The pixels of an EXR written by ``save_exr`` (float32, top row first)."""
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        key = next(k for k in ("RGBA", "RGB", "Y") if k in ch) if any(k in ch for k in ("RGBA", "RGB", "Y")) \
            else next(iter(ch))
        return np.array(ch[key].pixels, dtype=np.float32)
