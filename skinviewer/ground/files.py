"""Files are never half-written: every write goes to a temporary file in the target's folder and
is renamed over the target only when complete."""
from __future__ import annotations

import errno
import io
import os
import re
import stat
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np


def _read_umask() -> int:
    mask = os.umask(0)  # the only way to read it; done once, at import, before any thread starts
    os.umask(mask)
    return mask


_UMASK = _read_umask()


class FileReadError(OSError):
    """A file that is not read: missing, not a regular file (FIFO, device, folder), or too large."""


def read_regular_file(path: str | os.PathLike[str], limit: int, what: str = "file") -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes. FIFOs, devices (/dev/zero) and folders
    are refused before any read (opened non-blocking, so a FIFO never hangs), and at most
    ``limit`` + 1 bytes are ever read (a file growing meanwhile is refused too)."""
    p = os.fspath(path)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        raise FileReadError(f"cannot read {what}: {getattr(exc, 'strerror', None) or exc}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = ("a folder" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode)
                    else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else "a socket")
            raise FileReadError(f"cannot read {what}: it is {kind}, not a regular file")
        if st.st_size > limit:
            raise FileReadError(f"cannot read {what}: {st.st_size / 2**20:.1f} MiB is over the "
                                f"{limit / 2**20:.0f} MiB limit")
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise FileReadError(f"cannot read {what}: larger than the {limit / 2**20:.0f} MiB limit")
        return b"".join(chunks)
    except FileReadError:
        raise
    except OSError as exc:
        raise FileReadError(f"cannot read {what}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


# our temporaries: ".<target name>.<pid>-<random>.tmp" (older builds: ".<target name>.<random>.tmp")
_TMP = re.compile(r"^\.(?P<target>.+)\.(?:(?P<pid>\d+)-)?[A-Za-z0-9_]{6,12}\.tmp$")
STALE_TMP_SECONDS = 600  # a temporary without a pid is stale after this long


def is_temporary(path: str | os.PathLike[str]) -> bool:
    """True for the temporaries atomic writes make (never a preset, never an image)."""
    return _TMP.match(Path(path).name) is not None


def list_files(folder: str | os.PathLike[str], pattern: str = "*.json") -> list[Path]:
    """Regular files of ``folder`` matching ``pattern``, without hidden files and our temporaries."""
    return sorted(p for p in Path(folder).glob(pattern)
                  if not p.name.startswith(".") and not is_temporary(p) and p.is_file())


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError as exc:
        return exc.errno != errno.ESRCH
    return True


def clean_stale_temporaries(target: str | os.PathLike[str]) -> int:
    """Remove temporaries of ``target`` left by a killed save: those whose writer process is gone
    (or, without a pid in the name, older than STALE_TMP_SECONDS). Returns how many went."""
    p = Path(target)
    removed = 0
    try:
        entries = list(os.scandir(p.parent))
    except OSError:
        return 0
    now = time.time()
    for e in entries:
        m = _TMP.match(e.name)
        if m is None or m.group("target") != p.name:
            continue
        try:
            if not e.is_file(follow_symlinks=False):
                continue
            pid = m.group("pid")
            stale = (not _pid_alive(int(pid))) if pid else now - e.stat(follow_symlinks=False).st_mtime > STALE_TMP_SECONDS
            if stale:
                os.unlink(e.path)
                removed += 1
        except OSError:
            continue
    return removed


@contextmanager
def atomic_path(path: str | os.PathLike[str], suffix: str = ".tmp") -> Iterator[Path]:
    """Yields a temporary path beside ``path``; on success it replaces ``path``, on error it goes.
    Temporaries of ``path`` left behind by a killed earlier save are removed first."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    clean_stale_temporaries(p)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.{os.getpid()}-", suffix=suffix, dir=str(p.parent))
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


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def save_png(path: str | os.PathLike[str], img: np.ndarray) -> Path:
    """uint8 (H, W, 3|4) image, top row first."""
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(img)).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


# what an image output's extension means: the display image in that format, or .exr the linear one
DISPLAY_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".tif": "TIFF", ".tiff": "TIFF", ".bmp": "BMP"}


class OutputPathError(ValueError):
    """An output path refused before anything is computed (its extension, or what it would replace)."""


def output_kind(path: str | os.PathLike[str], flag: str = "--out", linear: bool = True, display: bool = True) -> str:
    """"exr" or the Pillow format an output's extension names; OutputPathError (one line) for any
    other extension, so that no file is ever written with bytes its name does not say."""
    suffix = Path(os.fspath(path)).suffix.lower()
    if linear and suffix == ".exr":
        return "exr"
    if display and suffix in DISPLAY_FORMATS:
        return DISPLAY_FORMATS[suffix]
    names = ([".png", ".jpg", ".tif", ".bmp"] if display else []) + ([".exr"] if linear else [])
    raise OutputPathError(f"{flag} {_shown(path)}: the extension {suffix or '(none)'!r} is not an image format "
                          f"this writes; use {', '.join(names[:-1]) + ' or ' if len(names) > 1 else ''}{names[-1]}")


def _shown(path: str | os.PathLike[str]) -> str:
    return os.fspath(path).encode("utf-8", "backslashreplace").decode("utf-8") if isinstance(path, str) \
        else os.fsdecode(path).encode("utf-8", "backslashreplace").decode("utf-8")


def save_image(path: str | os.PathLike[str], img: np.ndarray) -> Path:
    """uint8 (H, W, 3|4) display image (top row first) in the format the extension names (PNG, JPEG
    (quality 95, alpha dropped), TIFF, BMP); OutputPathError for any other extension."""
    from PIL import Image
    fmt = output_kind(path, linear=False)
    a = np.ascontiguousarray(img)
    if fmt in ("JPEG", "BMP") and a.ndim == 3 and a.shape[2] == 4:
        a = np.ascontiguousarray(a[..., :3])
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format=fmt, **({"quality": 95} if fmt == "JPEG" else {}))
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def save_npy(path: str | os.PathLike[str], arr: np.ndarray) -> Path:
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(arr, dtype=np.float32))
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def save_exr(path: str | os.PathLike[str], img: np.ndarray, extra: dict[str, np.ndarray] | None = None) -> Path:
    """Linear float image (H, W), (H, W, 1|3|4) as OpenEXR (float32, ZIP), top row first: what
    compositing and VFX tools read. OpenEXR encodes into memory (its own file writer takes only a
    UTF-8 name and reports a full disk as a bare RuntimeError); the bytes go to ``path`` through
    atomic_write_bytes like every writer: nothing is ever half-written, any failure is one OSError
    naming the file.
    ``extra``: named (H, W, 3) layers beside it (channels NAME.R, NAME.G, NAME.B)."""
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
    for name, layer in (extra or {}).items():
        b = np.nan_to_num(np.asarray(layer, np.float32), nan=0.0, posinf=3e38, neginf=-3e38)
        for c, cn in enumerate("RGB"):
            channels[f"{name}.{cn}"] = np.ascontiguousarray(b[..., c])
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    try:
        buf = io.BytesIO()
        with OpenEXR.File(header, channels) as f:
            f.write(buf)
        atomic_write_bytes(path, buf.getvalue())
    except (OSError, RuntimeError, ValueError) as exc:
        why = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        full = getattr(exc, "errno", None) in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT)
        raise OSError(f"cannot write {_shown(path)}: {why}" + (" (is the disk full?)" if full else "")) from None
    return Path(path)


def load_exr(path: str | os.PathLike[str]) -> np.ndarray:
    """The pixels of an EXR written by ``save_exr`` (float32, top row first)."""
    import OpenEXR

    data = read_regular_file(path, 2**30, what=f"EXR {_shown(path)}")
    with OpenEXR.File(io.BytesIO(data)) as f:
        ch = f.channels()
        key = next(k for k in ("RGBA", "RGB", "Y") if k in ch) if any(k in ch for k in ("RGBA", "RGB", "Y")) \
            else next(iter(ch))
        return np.array(ch[key].pixels, dtype=np.float32)
