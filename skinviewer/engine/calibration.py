"""What each technique's preview rungs cost on the machine at hand (issue 27): the quality
governor's front, measured, not hard-coded.

``calibrate`` renders every rung of each technique's preview ladder (techniques/preview.py) on the
default settings and the scene given, and times two interaction frames (sync timing: glFinish +
wall clock per pass, medians): a **light move** (the key light nudged: texture-space and view
work re-run, what a light drag, most slider edits and a technique's own knobs cost) and a
**camera move** (only view-dependent work). Error figures against the ground truth come from the
last bench (``skinviewer bench``) where a rung matches a configuration it measured, else from
the shipped table (techniques/preview_errors.json, measured by ``benchmarks/bench_governor.py``).

The result is cached per GL renderer string and mesh size class in the cache folder, written
atomically; a file that is missing, unreadable, of another version or made for another ladder is
rebuilt (with a message), never trusted."""
from __future__ import annotations

import hashlib
import json
import re
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from skinviewer import techniques
from skinviewer.ground.files import atomic_write_text
from skinviewer.ground.paths import cache_dir
from skinviewer.ground.settings import Settings, with_values
from skinviewer.techniques.preview import Rung, ladder

if TYPE_CHECKING:
    import moderngl

    from skinviewer.engine.renderer import Renderer


VERSION = 1
SIZE_CLASSES = ((20_000, "small"), (250_000, "medium"))  # triangles below -> class; above: "large"
CALIBRATION_SIZE = (640, 640)  # the viewer's default render size: what the rungs are timed at
ERRORS_TABLE = Path(__file__).resolve().parents[1] / "techniques" / "preview_errors.json"


def renderer_name(ctx: moderngl.Context) -> str:
    """The GL renderer string a calibration is cached under (GL_RENDERER: the device and driver)."""
    return str(ctx.info.get("GL_RENDERER", "unknown"))


def mesh_class(triangles: int) -> str:
    """The mesh size class a calibration holds for (costs follow the triangle count only loosely:
    the maps and the view dominate, so three classes)."""
    for limit, name in SIZE_CLASSES:
        if triangles < limit:
            return name
    return "large"


def rung_key(technique: str, rung: Rung) -> str:
    """A stable name of one rung: technique, changes and scale (labels may be reworded)."""
    return json.dumps([technique, sorted((k, repr(v)) for k, v in rung.changes.items()), rung.scale])


@dataclass
class Entry:
    technique: str
    label: str
    changes: dict[str, Any]
    scale: float
    light_ms: float  # a light-move frame (texture-space + view work), sync timing, median
    camera_ms: float  # a camera-move frame (view work only)
    error: float | None = None  # mean relative RMS against the ground truth (None: not measured)
    error_source: str = ""  # "bench <path>" | "shipped table" | ""
    uncertainty: float | None = None  # the ground truth's own uncertainty of ``error`` (None: not stated)
    truth_version: int | None = None  # the ground truth's VERSION ``error`` was measured against (None: not recorded)

    @property
    def key(self) -> str:
        return rung_key(self.technique, Rung(self.label, self.changes, self.scale))


@dataclass
class Calibration:
    renderer: str  # GL_RENDERER
    mesh_class: str
    size: tuple[int, int]
    entries: dict[str, list[Entry]] = field(default_factory=dict)  # technique -> its rungs
    created: str = ""
    version: int = VERSION
    signature: dict[str, list[str]] = field(default_factory=dict)  # technique -> the ladder's rung keys

    def entry(self, technique: str, rung: Rung) -> Entry | None:
        key = rung_key(technique, rung)
        return next((e for e in self.entries.get(technique, []) if e.key == key), None)

    def to_json(self) -> dict[str, Any]:
        return {"version": self.version, "renderer": self.renderer, "mesh_class": self.mesh_class,
                "size": list(self.size), "created": self.created, "signature": self.signature,
                "timing": "sync (glFinish + wall clock per pass), median of the runs",
                "entries": {t: [asdict(e) for e in es] for t, es in self.entries.items()}}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Calibration:
        entries = {t: [Entry(**e) for e in es] for t, es in d["entries"].items()}
        for es in entries.values():
            for e in es:
                if not (e.light_ms >= 0 and e.camera_ms >= 0):  # also refuses NaN
                    raise ValueError(f"{e.technique} {e.label}: a negative or non-finite time")
        return cls(str(d["renderer"]), str(d["mesh_class"]), tuple(d["size"]), entries, str(d.get("created", "")),
                   int(d["version"]), {t: list(v) for t, v in d.get("signature", {}).items()})


def signature(names: list[str] | None = None) -> dict[str, list[str]]:
    """Techniques' ladders on the default settings, as rung keys: a calibration made for another
    ladder (the code changed) is stale."""
    base = Settings()
    out = {}
    for name in names or techniques.names():
        s = with_values(base, {"technique": name})
        out[name] = [rung_key(name, r) for r in ladder(s)]
    return out


def drop_stale(cal: Calibration) -> list[str]:
    """Remove the techniques whose ladder changed since ``cal`` was measured (or that no longer
    exist): their figures belong to other configurations. Returns their names; the rest stays."""
    today = set(techniques.names())
    held = sorted(cal.entries)
    now = signature([t for t in held if t in today])
    stale = [t for t in held if t not in today or cal.signature.get(t) != now.get(t)]
    for t in stale:
        cal.entries.pop(t, None)
        cal.signature.pop(t, None)
    return stale


def calibration_path(renderer: str, mclass: str) -> Path:
    slug = re.sub(r"[^a-z0-9]+", "-", renderer.lower()).strip("-")[:40]
    digest = hashlib.sha1(f"{renderer}|{mclass}".encode()).hexdigest()[:10]
    return cache_dir() / "calibration" / f"{slug}-{mclass}-{digest}.json"


# calibrations measured on GPUs by benchmarks/gpu/run.sh and shipped with the package (issue 31):
# used for exactly that GL renderer until this machine has its own
SHIPPED = Path(__file__).resolve().parents[1] / "techniques" / "calibrations"


def shipped(renderer: str, mclass: str, folder: Path | None = None) -> Calibration | None:
    """A shipped calibration of this GL renderer and mesh class: the techniques whose preview
    ladders are today's (a ladder changed since: that technique is measured here)."""
    for p in sorted((folder or SHIPPED).glob("*.json")):
        try:
            cal = Calibration.from_json(json.loads(p.read_text(encoding="utf-8")))
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if cal.version == VERSION and cal.renderer == renderer and cal.mesh_class == mclass:
            drop_stale(cal)
            if cal.entries:
                return cal
    return None


def load(renderer: str, mclass: str) -> tuple[Calibration | None, str]:
    """The cached calibration (else a shipped one of this renderer), or None and why it is to be
    (re)built (one line)."""
    path = calibration_path(renderer, mclass)
    if not path.is_file():
        cal = shipped(renderer, mclass)
        if cal is not None:
            return cal, ""
        return None, f"no calibration for {renderer} ({mclass} meshes) yet: measuring the techniques on this machine"
    try:
        cal = Calibration.from_json(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"calibration {path} unreadable ({type(exc).__name__}: {exc}): rebuilding it"
    if cal.version != VERSION or cal.renderer != renderer or cal.mesh_class != mclass:
        return None, f"calibration {path} is of another version or machine: rebuilding it"
    # the costs are this machine's; the error figures are the newest bench's or shipped table's
    # (a rung added since, or a table measured again, is not left without its figure)
    attach_errors(cal)
    stale = drop_stale(cal)
    if not cal.entries:
        return None, f"calibration {path} was made for other preview ladders: rebuilding it"
    if stale:  # the others are kept; these are measured again when first governed
        return cal, (f"calibration {path}: {', '.join(stale)} made for other preview ladders: "
                     f"measuring {'it' if len(stale) == 1 else 'them'} again")
    return cal, ""


def save(cal: Calibration) -> Path:
    path = calibration_path(cal.renderer, cal.mesh_class)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(cal.to_json(), indent=1) + "\n")
    return path


def _nudge_light(s: Settings, k: int) -> Settings:
    d = list(s.lights[0].direction)
    d[0] += 0.03 if k % 2 == 0 else -0.03
    return with_values(s, {"lights.0.direction": d})


def _nudge_camera(s: Settings, k: int) -> Settings:
    return with_values(s, {"camera.yaw": s.camera.yaw + (0.25 if k % 2 == 0 else -0.25)})


def rung_settings(s: Settings, rung: Rung) -> Settings:
    """``s`` with a rung's changes and its view scale applied to the render size."""
    changes = dict(rung.changes)
    if rung.scale != 1.0:
        changes["render.width"] = max(16, int(s.render.width * rung.scale))
        changes["render.height"] = max(16, int(s.render.height * rung.scale))
    return with_values(s, changes) if changes else s


def measure_rung(renderer: Renderer, s: Settings, runs: int = 2,
                 cancelled: Callable[[], bool] | None = None) -> tuple[float, float]:
    """(light-move ms, camera-move ms) of ``s``: medians of ``runs`` sync-timed frames each, after
    a warm-up frame (programs compiled, textures allocated, once-per-mesh maps made). ``cancelled``
    is asked between frames (InterruptedError): closing the viewer waits one frame, not a rung."""
    def ms(settings: Settings) -> float:
        if cancelled is not None and cancelled():
            raise InterruptedError("calibration cancelled")
        return renderer.render(settings, timing="sync").total_ms
    renderer.render_settled(s, timing="sync")
    light = [ms(_nudge_light(s, k)) for k in range(runs)]
    ms(s)
    cam = [ms(_nudge_camera(s, k)) for k in range(runs)]
    return statistics.median(light), statistics.median(cam)


def calibrate(renderer: Renderer, base: Settings,
 names: list[str] | None = None, runs: int = 2,
              progress: Callable[[str, int, int], None] | None = None,
              cancelled: Callable[[], bool] | None = None, into: Calibration | None = None) -> Calibration:
    """Time every rung of each technique's ladder (on ``base``'s scene, the default settings
    otherwise, CALIBRATION_SIZE) with ``renderer`` (an engine Renderer); error figures attached.
    ``into``: a calibration of the same renderer and mesh class to add these techniques to."""
    defaults = with_values(Settings(), {"scene": base.scene.model_dump(mode="json"),
                                        "render.width": CALIBRATION_SIZE[0], "render.height": CALIBRATION_SIZE[1]})
    scene = renderer.ensure_scene(defaults)
    tris = len(scene.gpu.mesh.indices)
    cal = Calibration(renderer_name(renderer.ctx), mesh_class(tris), CALIBRATION_SIZE,
                      created=time.strftime("%Y-%m-%d %H:%M:%S"))
    if into is not None and (into.renderer, into.mesh_class) == (cal.renderer, cal.mesh_class):
        cal.entries = {t: list(es) for t, es in into.entries.items()}
    names = list(names or techniques.names())
    for name in names:
        cal.entries.pop(name, None)
    todo = [(name, rung) for name in names for rung in ladder(with_values(defaults, {"technique": name}))]
    for n, (name, rung) in enumerate(todo):
        if cancelled is not None and cancelled():
            raise InterruptedError("calibration cancelled")
        if progress is not None:
            progress(f"{name}: {rung.label}", n, len(todo))
        s = rung_settings(with_values(defaults, {"technique": name}), rung)
        light, cam = measure_rung(renderer, s, runs, cancelled)
        cal.entries.setdefault(name, []).append(Entry(name, rung.label, dict(rung.changes), rung.scale, light, cam))
        renderer.trim()
    cal.signature = signature(sorted(cal.entries))
    attach_errors(cal)
    return cal


def _version(v: object) -> int | None:
    return v if isinstance(v, int) and not isinstance(v, bool) else None


def attach_errors(cal: Calibration, bench_results: str | Path | None = None) -> None:
    """Error figures for the entries: the last bench's where it measured the same configuration
    (the defaults with the rung's changes, at full view), else the shipped table's; each with the
    ground truth's version it was measured against (``truth_note``: an older one is said)."""
    shipped: dict[str, float] = {}
    shipped_u: dict[str, float] = {}
    shipped_v: int | None = None
    try:
        table = json.loads(ERRORS_TABLE.read_text(encoding="utf-8"))
        shipped, shipped_u = table.get("errors", {}), table.get("uncertainty", {})
        shipped_v = _version(table.get("truth_version"))
    except (OSError, ValueError, AttributeError):
        pass
    bench = _bench_errors(bench_results)
    for es in cal.entries.values():
        for e in es:
            key = e.key
            if key in bench:
                e.error, e.uncertainty, e.error_source, e.truth_version = bench[key]
            elif key in shipped:
                e.error, e.error_source, e.truth_version = float(shipped[key]), "shipped table", shipped_v
                u = shipped_u.get(key)
                e.uncertainty = float(u) if isinstance(u, (int, float)) else None


def truth_version() -> int:
    """The ground truth's VERSION today (engine/reference): error figures of another were measured
    against a truth whose value or uncertainty has changed since."""
    from skinviewer.engine.reference import VERSION
    return VERSION


def truth_note(e: Entry) -> str:
    """"" when ``e``'s error was measured against today's ground truth (or it has none), else which
    truth it was: "truth version 8, now 10" (issue 30: a figure carries its ruler)."""
    now = truth_version()
    if e.error is None or e.truth_version == now:
        return ""
    return (f"truth version {e.truth_version}, now {now}" if e.truth_version is not None
            else f"truth version not recorded, now {now}")


def stale_truth(cal: Calibration | None) -> str:
    """One line when some of ``cal``'s error figures were measured against another ground truth than
    today's (their source and version), else ""."""
    if cal is None:
        return ""
    old: dict[tuple[str, int | None], int] = {}
    for es in cal.entries.values():
        for e in es:
            if truth_note(e):
                k = (e.error_source, e.truth_version)
                old[k] = old.get(k, 0) + 1
    if not old:
        return ""
    parts = [f"{n} from the {src} (truth version {v if v is not None else 'not recorded'})"
             for (src, v), n in sorted(old.items(), key=lambda kv: str(kv[0]))]
    return (f"the governor's error figures were measured against an older ground truth than today's (version "
            f"{truth_version()}): {'; '.join(parts)}; rerun benchmarks/bench_governor_errors.py or skinviewer bench")


def _bench_errors(path: str | Path | None) -> dict[str, tuple[float, float | None, str, int | None]]:
    from skinviewer.engine.bench import last_bench, load_results
    path = path or last_bench()
    if not path:
        return {}
    try:
        data, results = load_results(path)
        ref = data.get("reference")
        version = _version(ref.get("version")) if isinstance(ref, dict) else None
    except Exception:  # an unreadable bench: no figures from it (the shipped table stays)
        return {}
    out = {}
    for r in results:
        if r.rms_mean is not None and not r.error:
            out[rung_key(r.technique, Rung(r.label, dict(r.changes), 1.0))] = (r.rms_mean, r.rms_mean_u, f"bench {path}",
                                                                               version)
    return out
