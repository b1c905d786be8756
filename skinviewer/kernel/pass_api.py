"""What a render pass is and declares: ``Pass`` (reflect / execute), the ``Reflection`` it fills in
reflect (settings, inputs, outputs with their ``TexSpec``, programs, and the ``Plan`` it hands to
execute), read-only ``SettingsView``s and the errors of the graph."""
from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, TypeVar, cast

from pydantic import BaseModel

from skinviewer.ground.settings import Settings, get_path

if TYPE_CHECKING:
    from skinviewer.kernel.execute import ExecuteContext
    from skinviewer.kernel.frame_view import FrameView

Defines = tuple[tuple[str, object], ...]  # a program's #defines, sorted: part of its cache key
ShapeState = dict[object, Any]  # the graph's memory for shape decisions: each pass keys and types its own entries


_DTYPES = {"f1": 1, "f2": 2, "f4": 4}


@dataclass(frozen=True)
class TexSpec:
    """An output texture: size (w, h), components 1-4, dtype f1 (8-bit unorm), f2 or f4 (float).
    Anything lit is f2 or f4. ``depth`` adds a depth renderbuffer to the pass's framebuffer."""
    size: tuple[int, int]
    components: int = 4
    dtype: str = "f2"
    filter: str = "linear"
    depth: bool = False

    def __post_init__(self) -> None:
        if self.dtype not in _DTYPES or not 1 <= self.components <= 4:
            raise ValueError(f"bad texture spec {self}")
        if self.size[0] < 1 or self.size[1] < 1:
            raise ValueError(f"bad texture size {self.size}")

    @property
    def nbytes(self) -> int:
        return self.size[0] * self.size[1] * self.components * _DTYPES[self.dtype]


class GraphError(RuntimeError):
    pass


class ResourceLimitError(GraphError):
    """A configuration whose textures would not fit in the memory available: refused before any
    allocation, with the figure (``needed``, ``available`` in bytes)."""

    def __init__(self, needed: int, available: int, biggest: list[tuple[str, int]]):
        self.needed, self.available = needed, available
        top = ", ".join(f"{name} {_gb(b)}" for name, b in biggest[:3])
        super().__init__(f"this configuration needs {_gb(needed)} of texture memory but only {_gb(available)} "
                         f"is available (largest: {top}); lower render/map sizes")


def _gb(n: int) -> str:
    return f"{n / 1e9:.2f} GB" if n >= 1e8 else f"{n / 1e6:.1f} MB"


class Plan(Mapping[str, Any]):
    """What a pass's ``reflect`` decided for this frame (``Reflection.plan``), handed to its
    ``execute`` as ``ec.plan``: read-only, by attribute (``ec.plan.k``) or item. Execute reads its
    decisions here instead of taking them again (Filament's ``addPass<Data>(setup, execute)``)."""
    __slots__ = ("_values",)
    _values: Mapping[str, Any]

    def __init__(self, values: Mapping[str, Any] | None = None):
        object.__setattr__(self, "_values", MappingProxyType(dict(values or {})))

    def __getitem__(self, name: str) -> Any:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __getattr__(self, name: str) -> Any:
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(f"the plan has no '{name}' (reflect planned: {sorted(self._values)})") from None

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("a plan is read-only: reflect decides it (Reflection.plan)")

    def __repr__(self) -> str:
        return f"Plan({dict(self._values)!r})"


_T = TypeVar("_T")


_FIELDS: dict[type, frozenset[str]] = {}  # a section's field names (model_fields costs ~1 us a read)


def _fields(model: type) -> frozenset[str]:
    names = _FIELDS.get(model)
    if names is None:
        names = _FIELDS[model] = frozenset(model.model_fields)  # type: ignore[attr-defined]
    return names


_MODEL: dict[type, bool] = {}  # whether a type is a section (isinstance on pydantic's ABC metaclass is slow)


def _is_model(t: type) -> bool:
    m = _MODEL.get(t)
    if m is None:
        m = _MODEL[t] = issubclass(t, BaseModel)
    return m


def _composite(value: Any) -> bool:
    """A settings value read field by field (a section, or a list of sections such as ``lights``)."""
    t = type(value)
    return _is_model(t) or (t is list and bool(value) and _is_model(type(value[0])))


class _Leaf:
    """A field's value read through a SettingsNode, with its dotted path (SettingsNode._kids)."""
    __slots__ = ("value", "path")

    def __init__(self, value: Any, path: str):
        self.value, self.path = value, path


class SettingsNode:
    """Typed attribute access to the settings that declares each read by its dotted path, exactly as
    ``Reflection.setting(path)`` does (issue 28): ``r.settings.deon.mix`` declares ``deon.mix`` and
    returns its value; ``r.settings.lights[1].enabled`` declares ``lights.1.enabled``;
    ``len(r.settings.lights)`` declares ``lights.#``; iterating or slicing a list declares the whole
    list (``lights``); ``whole(r.settings.lights[1])`` declares and returns a whole section
    (``lights.1``). A section (or list of sections) is returned as another node, a field's value as
    itself. The graph keys a pass's cache on what was declared, so passes never name a path in a
    string. Type checkers see ``Settings`` (``Reflection.settings``), so a misspelt field fails there."""
    __slots__ = ("_value", "_path", "_on_read", "_kids")
    _value: Any
    _path: str
    _on_read: Any
    _kids: dict[str | int, SettingsNode | _Leaf]

    def __init__(self, value: Any, path: str, on_read: Any):
        object.__setattr__(self, "_value", value)
        object.__setattr__(self, "_path", path)
        object.__setattr__(self, "_on_read", on_read)
        object.__setattr__(self, "_kids", {})  # the sections under it, made once (the settings are immutable here)

    def _child(self, value: Any, part: str) -> Any:
        path = f"{self._path}.{part}" if self._path else part
        if _composite(value):
            kid = self._kids[part] = SettingsNode(value, path, self._on_read)
            return kid
        self._kids[part] = _Leaf(value, path)  # the next read of it: one dict look-up (__getattr__)
        if self._on_read is not None:
            self._on_read(path)
        return value

    def _whole(self) -> Any:
        if self._on_read is not None:
            self._on_read(self._path)
        return self._value

    def _again(self, kid: Any) -> Any:
        """A field read before through this node: its node, or its value with the read declared again."""
        if type(kid) is _Leaf:
            if self._on_read is not None:
                self._on_read(kid.path)
            return kid.value
        return kid

    def __getattr__(self, name: str) -> Any:
        # a field read before through this node (reflect reads the same fields many times): its node,
        # or its value with the read declared again -- the settings do not change under a node
        kid = self._kids.get(name)
        if kid is not None:
            return self._again(kid)
        v = self._value
        if name[0] == "_" or not _is_model(type(v)) or name not in _fields(type(v)):
            raise AttributeError(f"settings '{self._path or '<root>'}' have no field '{name}'")
        return self._child(getattr(v, name), name)

    def __getitem__(self, key: int | slice) -> Any:
        v = self._value
        if type(v) is not list:
            raise TypeError(f"settings '{self._path}' are not a list")
        if type(key) is int and 0 <= key < len(v):
            kid = self._kids.get(key)
            if kid is not None:
                return self._again(kid)
            kid = self._child(v[key], str(key))
            self._kids[key] = self._kids[str(key)]
            return kid
        if isinstance(key, slice):
            return self._whole()[key]
        raise IndexError(f"settings '{self._path}' have no item {key!r}")

    def __len__(self) -> int:
        if not isinstance(self._value, list):
            raise TypeError(f"settings '{self._path}' are not a list")
        if self._on_read is not None:
            self._on_read(f"{self._path}.#")
        return len(self._value)

    def __iter__(self) -> Iterator[Any]:
        if not isinstance(self._value, list):
            raise TypeError(f"settings '{self._path}' are a section: read its fields, or whole() it")
        return iter(self._whole())

    def __bool__(self) -> bool:
        raise TypeError(f"settings '{self._path}' are a section: read a field, or whole() it")

    def __eq__(self, other: object) -> bool:
        raise TypeError(f"settings '{self._path}' are a section: read a field, or whole() it")

    __hash__ = None  # type: ignore[assignment]

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("settings are read-only in a pass")

    def __repr__(self) -> str:
        return f"SettingsNode({self._path!r})"


def whole(value: _T) -> _T:
    """A whole section or list read through ``r.settings`` / ``ec.settings`` (``whole(r.settings.lights[i])``):
    declares its path (``lights.i``) and returns the settings object itself; a field's value as is."""
    if isinstance(value, SettingsNode):
        return cast(_T, value._whole())
    return value


def declare(*values: object) -> None:
    """Reflect reads what execute will read, so the graph keys the cache on it:
    ``declare(ph.ambient, ph.specular)`` (the reads through ``r.settings`` declared them; a section
    or list, ``declare(r.settings.deon.gaussians)``, is declared whole)."""
    for v in values:
        whole(v)


# what a memoised rule read besides its declared settings (Reflection.memo): ("peek", path), ("raw",) (the
# settings object itself), ("view", attribute, value: the camera by its key, floats by repr), ("state", key,
# value or MISSING; OPAQUE: not comparable), ("write", key, value) (a shape-state write, in order), ("memo",
# key, answer) (a rule it asked: its answer, settings read, notes and drops; what that one read is its own)
Read = tuple[Any, ...]
MISSING = object()
OPAQUE = object()
_PLAIN = (bool, int, str, type(None))


def read_value(name: str, value: Any) -> Any:
    """How a view attribute's value is kept in a Read: comparable by ==, bit-exact for floats."""
    if name == "camera":
        return value.key()
    if type(value) is float:
        return repr(value)
    if type(value) in _PLAIN:
        return value
    return ("id", id(value))  # the scene: the same object (the graph checks it is)


class _ViewReads:
    """The frame's view as a memoised rule sees it: each attribute read recorded (Read "view")."""
    __slots__ = ("_view", "_reads")

    def __init__(self, view: Any, reads: list[Read]):
        self._view, self._reads = view, reads

    def __getattr__(self, name: str) -> Any:
        value = getattr(self._view, name)
        self._reads.append(("view", name, read_value(name, value)))
        return value


def state_value(value: Any) -> Any:
    """How a shape-state value is kept in a Read: comparable by ==, bit-exact for floats; OPAQUE else."""
    if value is MISSING or type(value) in _PLAIN:
        return value
    return ("float", repr(value)) if type(value) is float else OPAQUE


class _StateReads:
    """The graph's shape state as a memoised rule sees it: reads and writes recorded (Reads "state",
    "write"); what a rule does with it beyond get / [] / in / setdefault is recorded as not comparable."""
    __slots__ = ("_state", "_reads")

    def __init__(self, state: ShapeState, reads: list[Read]):
        self._state, self._reads = state, reads

    def _note(self, *read: Any) -> None:
        self._reads.append(read)

    def get(self, key: Any, default: Any = None) -> Any:
        value = self._state.get(key, MISSING)
        self._note("state", key, state_value(value))
        return default if value is MISSING else value

    def __getitem__(self, key: Any) -> Any:
        value = self._state.get(key, MISSING)
        self._note("state", key, state_value(value))
        return self._state[key]

    def __contains__(self, key: Any) -> bool:
        self._note("state", key, state_value(self._state.get(key, MISSING)))
        return key in self._state

    def __setitem__(self, key: Any, value: Any) -> None:
        self._note("write", key, value)
        self._state[key] = value

    def setdefault(self, key: Any, default: Any = None) -> Any:
        if key not in self:
            self[key] = default
        return self[key]

    def __iter__(self) -> Any:
        """Its keys (a rule dropping what another scene kept: passes/view_cull): not comparable."""
        self._note("state", "__iter__", OPAQUE)
        return iter(list(self._state))

    def __delitem__(self, key: Any) -> None:
        self._note("write", key, MISSING)
        del self._state[key]

    def __getattr__(self, name: str) -> Any:
        self._note("state", name, OPAQUE)
        return getattr(self._state, name)


class Reflection:
    """What a pass declares for this frame (``Pass.reflect`` fills it)."""

    def __init__(self, settings: Settings, scene: Any = None, state: ShapeState | None = None,
                 view: FrameView | None = None, interactive: bool = False):
        self._settings_value = settings
        # a governed preview frame (FrameInputs.interactive): a scene rule may answer from a coarser,
        # cached estimate (rules.tsm_needed); the final image's frames are never interactive
        self.interactive = interactive
        self.scene = scene  # the GpuScene: its shape may decide the graph's (uses_scene passes)
        self._view = view  # the frame's view of the scene and camera (Reflection.view)
        self.declared: list[str] = []  # the settings read, by dotted path: the cache keys on them
        self._declared_set: set[str] = set()
        self.inputs: list[str] = []
        self.outputs: dict[str, TexSpec] = {}
        self.programs: list[tuple[str, Defines]] = []
        # scene-driven rules (passes/rules.py): why this pass is skipped, why a consumer no longer
        # reads a resource (its producer is pruned with that reason), notes for the frame report
        self.skip_reason: str | None = None
        self.dropped: dict[str, str] = {}
        self.notes: list[str] = []
        self._state = state if state is not None else {}  # the graph's memory for shape decisions (state)
        # what this reflect read besides its declared settings, so that the graph may reuse it next frame
        # (RenderGraph._reusable): settings peeked (paths), rules asked through memo (key, rule, scene-less),
        # and whether it read the view, the shape state or the raw settings outside a memoised rule
        self._peek_paths: list[str] = []
        self._memos: list[tuple[Any, Callable[[Reflection], Any], bool]] = []  # (key, rule, scene is None)
        self._untracked = False
        self.depends_on: dict[str, Any] = {}  # values outside settings/inputs the output depends on
        # kernel/coverage: the tile cells this pass's outputs must hold this frame (Reflection.cover); None: all
        self.cover_need: Any = None
        self._plan: dict[str, Any] = {}  # what reflect decided, for execute (Reflection.plan)
        # the graph's per-frame memo of rules many passes ask (Reflection.memo); None: no memo
        self._frame_memo: dict[Any, tuple[Any, list[str], list[str], list[tuple[str, str]], list[Read]]] | None = None
        self._recorders: list[tuple[list[str], list[str], list[tuple[str, str]], list[Read]]] = []
        self._reads = SettingsNode(settings, "", self._declare)  # r.settings
        self._peeks = SettingsNode(settings, "", self._peek_read)  # r.peeked (recorded, not declared)

    @property
    def view(self) -> FrameView:
        """The frame's view of the scene and camera (kernel/frame_view.FrameView, built once a frame by
        the renderer; ``ec.view`` is its camera): what the scene rules (passes/rules.py) measure --
        the screen coverage, the camera a thin part must be in view of. Passes that use the scene get it."""
        if not self._recorders:
            self._untracked = True
        if self._view is None:
            raise GraphError("this reflection has no frame view (FrameInputs.frame_view: the renderer builds "
                             "one a frame; a scene rule needs it)")
        if self._recorders:  # inside a memoised rule: what it reads of the view is recorded (_ViewReads)
            return cast("FrameView", _ViewReads(self._view, self._recorders[-1][3]))
        return self._view

    def skip(self, reason: str) -> None:
        """This pass is not needed this frame (declare nothing else); reported "pruned: reason"."""
        self.skip_reason = reason

    def drop(self, resource: str, reason: str, record: bool = True) -> None:
        """This pass does not read ``resource`` this frame because of ``reason``: when nothing else
        reads it its producer is reported "pruned: reason"."""
        if record:
            for rec in self._recorders:
                rec[2].append((resource, reason))
        self.dropped.setdefault(resource, reason)

    def note(self, text: str, record: bool = True) -> None:
        """A scene-driven choice shown with the pass in the frame report (e.g. a map size)."""
        if record:
            for rec in self._recorders:
                rec[1].append(text)
        if text not in self.notes:
            self.notes.append(text)

    def plan(self, **values: Any) -> None:
        """Record what this reflect decided (sizes, resource names, counts, defines...) for execute to
        read as ``ec.plan.name``, so it is decided once. Part of the pass's cache key (by ``repr``):
        keep values small and immutable (numbers, strings, tuples, TexSpecs). A name planned twice
        must get the same value."""
        for name, value in values.items():
            if name in self._plan and self._plan[name] != value:
                raise GraphError(f"plan '{name}' decided twice with different values "
                                 f"({self._plan[name]!r}, {value!r})")
            self._plan[name] = value

    @property
    def planned(self) -> Plan:
        """The plan recorded so far (what ``ec.plan`` will be)."""
        return Plan(self._plan)

    @property
    def state(self) -> ShapeState:
        """The graph's memory for shape decisions (hysteresis of the scene rules)."""
        if not self._recorders:
            self._untracked = True
            return self._state
        return cast(ShapeState, _StateReads(self._state, self._recorders[-1][3]))  # recorded inside a memoised rule

    @property
    def _settings(self) -> Settings:
        """The settings object itself, read by a scene rule (undeclared: the rule declares what it needs)."""
        if not self._recorders:
            self._untracked = True
        if self._recorders:
            self._recorders[-1][3].append(("raw",))
        return self._settings_value

    def _peek_read(self, path: str) -> None:
        self._peek_paths.append(path)
        if self._recorders:
            self._recorders[-1][3].append(("peek", path))

    def memo(self, key: Any, rule: Callable[[Reflection], _T]) -> _T:
        """``rule(self)``, or what it returned for ``key`` in an earlier pass's reflect of this frame: a
        scene rule that many passes ask the same question (d'Eon's map size, blur plan, TSM light, the
        kernel-under-a-pixel rule) is answered once a frame. On a hit, what the rule did to its
        reflection is done again to this one: the settings it read are declared (so cache keys are
        as without the memo), its notes noted and its drops dropped. ``key`` must name everything the
        answer depends on besides the frame's settings, scene, view and state (e.g. whether this pass
        uses the scene); ``rule`` reads only through the reflection it is given (the graph asks it
        again, in a reflection of its own, to tell whether a pass's last reflection still holds).
        Outside a graph's frame (no memo): ``rule(self)``. The answer is kept with what the rule read
        besides its declared settings (``Read``s: settings peeked, the raw settings, the view's
        attributes, the shape state read and written), so the graph can tell, without asking again,
        that it would answer the same next frame (RenderGraph._recall)."""
        memo = self._frame_memo
        if memo is None:
            return rule(self)
        if not self._recorders:  # a rule this pass asked itself: re-asked when the graph reuses the reflection
            self._memos.append((key, rule, self.scene is None))
        hit = memo.get(key)
        if hit is None:
            rec: tuple[list[str], list[str], list[tuple[str, str]], list[Read]] = ([], [], [], [])
            self._recorders.append(rec)
            try:
                value = rule(self)
            finally:
                self._recorders.remove(rec)
            memo[key] = hit = (value, *rec)
            if self._recorders:  # asked inside another rule: that one read this answer
                self._recorders[-1][3].append(("memo", key, hit[:4]))
        else:
            for outer in self._recorders:  # a memo asked inside another's make: the outer records it too
                outer[0].extend(hit[1])
                outer[1].extend(hit[2])
                outer[2].extend(hit[3])
            if self._recorders:
                self._recorders[-1][3].append(("memo", key, hit[:4]))
            for path in hit[1]:
                self._declare(path, record=False)
            for text in hit[2]:
                self.note(text, record=False)
            for resource, reason in hit[3]:
                self.drop(resource, reason, record=False)
        return cast(_T, hit[0])

    def _declare(self, path: str, record: bool = True) -> None:
        if record and self._recorders:
            for rec in self._recorders:
                rec[0].append(path)
        if path not in self._declared_set:  # a set beside the list: reflect reads a path many times
            self._declared_set.add(path)
            self.declared.append(path)

    @property
    def settings(self) -> Settings:
        """The settings, read by attribute; every read is declared (``SettingsNode``):
        ``r.settings.deon.mix``, ``r.settings.lights[i].enabled``, ``whole(r.settings.lights[i])``."""
        return cast(Settings, self._reads)

    @property
    def peeked(self) -> Settings:
        """The settings read without declaring them (as ``peek``): only for the graph's shape."""
        return cast(Settings, self._peeks)

    def setting(self, path: str) -> Any:
        """Declare a setting (dotted path) and return its current value (tests and tools; passes
        read ``r.settings``)."""
        self._declare(path)
        return get_path(self._settings_value, path)

    def peek(self, path: str) -> Any:
        """Read a setting without declaring it: only for the graph's shape (e.g. whether light i
        exists), never for a value the pass's output depends on."""
        self._peek_read(path)
        return get_path(self._settings_value, path)

    def depends(self, name: str, value: Any, scene_generation: bool = False) -> None:
        """The output also depends on ``value`` (e.g. a progressive pass's frame index, kept in
        ``state``): part of the cache key, so the pass re-runs when it changes. Its reflect then runs
        every frame (the graph cannot tell whether the value changed without asking), but for
        ``scene_generation``: the value is the scene's ``env_generation``, which the graph watches."""
        if not scene_generation:
            self._untracked = True
        self.depends_on[name] = value

    def cover(self, need: Any) -> None:
        """This frame needs the outputs valid only on the cells of ``need`` (a kernel/coverage.TileCover, from
        a memoised rule: not part of the cache key). The graph runs the pass when its key changed (the pass
        computes ``need``) or when the cells it holds under its key do not cover ``need`` (it computes the
        missing ones: ``ExecuteContext.cover``), and keeps it cached otherwise."""
        self.cover_need = need

    def input(self, resource: str) -> None:
        if resource not in self.inputs:
            self.inputs.append(resource)

    def output(self, resource: str, spec: TexSpec) -> None:
        self.outputs[resource] = spec

    def program(self, name: str, **defines: object) -> None:
        """Declare a program, compiled with these ``#define``s (a specialised variant; the defines
        are part of the cache key). ``ec.program(name)`` then returns it."""
        key: tuple[str, Defines] = (name, tuple(sorted(defines.items())))
        if key not in self.programs:
            self.programs.append(key)

    def section(self, prefix: str, fields: Iterable[str]) -> SettingsView:
        """Declare the settings ``prefix.f`` for each field and return them as a read-only view."""
        return SettingsView(prefix, {f: self.setting(f"{prefix}.{f}") for f in fields})


class SettingsView:
    """Read-only attribute view of some declared settings (``view.m``); only the declared fields."""
    __slots__ = ("_prefix", "_values")

    def __init__(self, prefix: str, values: dict[str, Any]):
        object.__setattr__(self, "_prefix", prefix)
        object.__setattr__(self, "_values", dict(values))

    def __getattr__(self, name: str) -> Any:
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(f"settings view '{self._prefix}' has no field '{name}' "
                                 f"(declared: {sorted(self._values)})") from None

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"settings view '{self._prefix}' is read-only")

    def __repr__(self) -> str:
        return f"SettingsView({self._prefix!r}, {self._values!r})"


class Pass:
    """Base class of render passes. Subclasses set ``name`` (unique in a graph), override
    ``reflect`` and ``execute``. ``view_dependent`` passes re-run when the camera moves;
    ``uses_scene`` passes re-run when the mesh, its maps or its units change. ``reflect`` reads
    only through its Reflection (settings, scene, view, memoised rules): the graph reuses a
    reflection while what it read is unchanged. A pass whose reflect reads state of its own that
    changes from outside declares it with ``r.depends`` (then it is reflected every frame)."""
    name: str = "pass"
    view_dependent: bool = False
    uses_scene: bool = True
    # a pass whose draws into its outputs are per-fragment independent (issue 27): under a frame time
    # budget the graph runs it in row bands (ExecuteContext.band / tile / held), across frames if need be
    tileable: bool = False

    def reflect(self, r: Reflection) -> None:
        raise NotImplementedError

    def execute(self, ec: ExecuteContext) -> None:
        raise NotImplementedError

    def release(self) -> None:
        """Free GL objects the pass made itself (VAOs, LUT textures)."""


