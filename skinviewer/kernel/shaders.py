"""Shader library: compiles programs from ``shaders/`` with ``#include`` of shared snippets,
remembers source files and modification times, and recompiles on demand. Compile errors come back
as (file, line, message) records; the last good program keeps running.

A program ``name`` is ``name.frag`` plus a vertex stage: ``name.vert``, or the shared stage its
fragment file names with ``#pragma vertex_stage "vs/fullscreen.vert"`` (paths relative to the root);
or, with no ``name.frag``, the compute shader ``name.comp`` (GL 4.3; a ``moderngl.ComputeShader``,
dispatched with ``ExecuteContext.dispatch``).
Every program gets the shared constants (``skinviewer.ground.constants.GLSL_DEFINES``), then the
library's own defines, then the program's defines, as ``#define`` lines after ``#version``."""
from __future__ import annotations

import hashlib
import os
import re
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import moderngl

from skinviewer.ground import paths
from skinviewer.ground.constants import GLSL_DEFINES
from skinviewer.ground.files import FileReadError, read_regular_file

MAX_SHADER_BYTES = 4 * 2**20  # one GLSL file; a FIFO or device among the shaders is refused, never read

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')
_VERTEX_STAGE = re.compile(r'^\s*#pragma\s+vertex_stage\s+"([^"]+)"\s*$', re.M)
_EXTENSION = re.compile(r"^\s*#extension\b")  # moved after #version: GLSL allows it only before any code
# "uniform <type> a, b[4];" with optional layout(...) and precision qualifiers
_UNIFORM = re.compile(r"^\s*(?:layout\s*\([^)]*\)\s*)?uniform\s+([^;{]+);", re.M)
# Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error C0000: ..."; AMD/Intel: "ERROR: 0:12: ..."
_ERR_PATTERNS = (
    re.compile(r"^\s*(\d+):(\d+)\(\d+\):\s*(?:error|warning)?:?\s*(.*)$"),
    re.compile(r"^\s*(\d+)\((\d+)\)\s*:\s*(?:error|warning)?\s*(.*)$"),
    re.compile(r"^\s*(?:ERROR|WARNING):\s*(\d+):(\d+):\s*(.*)$"),
)
STAGES = {"vertex_shader": ".vert", "fragment_shader": ".frag", "geometry_shader": ".geom", "compute_shader": ".comp"}


@dataclass(frozen=True)
class ShaderError:
    file: str
    line: int
    message: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.message}"


class ShaderCompileError(RuntimeError):
    def __init__(self, name: str, errors: list[ShaderError]):
        self.name = name
        self.errors = errors
        super().__init__(f"shader program '{name}' does not compile:\n" + "\n".join(map(str, errors)))


@dataclass
class _Entry:
    name: str
    defines: tuple[tuple[str, str], ...]
    program: moderngl.Program | None = None
    mtimes: dict[Path, float] = field(default_factory=dict)
    digest: str = ""
    errors: list[ShaderError] = field(default_factory=list)
    generation: int = 0  # bumps each time a new program replaces the old one
    declared: frozenset[str] = frozenset()  # uniform names declared in the running program's source
    drawn: bool = False  # the running program has been drawn (a driver JIT-compiles it at its first draw)
    members: frozenset[str] | None = None  # the running program's live names (``name in prog`` scans them)


def declared_uniforms(source: str) -> set[str]:
    """Names of the uniforms declared in preprocessed GLSL (compilers drop unused ones from the
    program; this says which names the source has at all)."""
    out = set()
    for m in _UNIFORM.finditer(source):
        decl = m.group(1).split()
        rest = " ".join(decl[1:]) if decl[0] not in ("lowp", "mediump", "highp") else " ".join(decl[2:])
        for part in rest.split(","):
            name = part.split("[")[0].split("=")[0].strip()
            if name.isidentifier():
                out.add(name)
    return out


FIRST_DRAWS_ENV = "SKINVIEWER_FIRST_DRAWS"  # 1: time and print every program's first draw


class ShaderLibrary:
    """Programs by (name, defines). ``defines``: library-wide extra defines (e.g. ``{"GENERIC_SHADERS":
    1}`` compiles every program unspecialised, for tests and comparisons)."""

    def __init__(self, ctx: moderngl.Context, root: Path | None = None, defines: dict[str, Any] | None = None,
                 include_roots: tuple[Path, ...] = ()):
        self.ctx = ctx
        self.root = Path(root) if root else paths.shaders_dir()
        # folders besides the root that #include / vertex_stage may read (a test's programs in a
        # temporary folder including the product's lib/); nothing else is ever read
        self.include_roots = tuple(Path(r) for r in include_roots)
        self.defines = {**GLSL_DEFINES, **{str(k): str(v) for k, v in (defines or {}).items()}}
        self._entries: dict[tuple[str, tuple[tuple[str, str], ...]], _Entry] = {}
        self._by_program: dict[int, _Entry] = {}
        self._release_hooks: list[Callable[[moderngl.Program], None]] = []
        self.revision = 0  # bumps whenever any program is replaced (a cheap "did any shader change?")
        # first draws (issue 27): llvmpipe -- and GPU drivers too -- finish a program at its first
        # draw, not at link (ctx.program took <= 16 ms, d'Eon's final pass's first draw ~0.5 s);
        # counted always, timed (glFinish before and after) with SKINVIEWER_FIRST_DRAWS=1
        self.first_draws = 0
        self.time_first_draws = os.environ.get(FIRST_DRAWS_ENV, "").strip() not in ("", "0")
        self.first_draw_log: list[tuple[str, dict[str, str], float]] = []  # (name, defines, ms) when timed

    # -- source assembly ---------------------------------------------------------------------
    def _expand(self, path: Path, files: list[Path], stack: tuple[Path, ...] = (),
                watch: set[Path] | None = None) -> list[str]:
        """Source lines with includes spliced in and #line directives so errors map to files.
        ``watch`` collects every file the result depends on, including ones that are missing or
        fail, so that a hot reload notices when they are restored or fixed."""
        if watch is not None:
            watch.add(path)
        if path in stack:
            raise _SourceError(ShaderError(self._rel(stack[-1]), 0, f"#include cycle through {self._rel(path)}"))
        outside = self._outside(path)
        if outside:
            where = self._rel(stack[-1]) if stack else self._rel(path)
            raise _SourceError(ShaderError(where, 0, outside))
        try:
            text = read_regular_file(path, MAX_SHADER_BYTES, what=self._rel(path)).decode("utf-8")
        except FileReadError as exc:
            where = self._rel(stack[-1]) if stack else self._rel(path)
            raise _SourceError(ShaderError(where, 0, str(exc))) from None
        except UnicodeDecodeError as exc:
            raise _SourceError(ShaderError(self._rel(path), text_line(path, exc.start), "not UTF-8 text: "
                                           f"byte 0x{exc.object[exc.start]:02x} at offset {exc.start}")) from None
        if path not in files:
            files.append(path)
        fid = files.index(path)
        out: list[str] = []
        src_lines = text.splitlines()
        for lineno, line in enumerate(src_lines, start=1):
            m = _INCLUDE.match(line)
            if _VERTEX_STAGE.match(line):
                out.append("// " + line.strip())  # read by _stage_files; keeps line numbers
            elif m:
                candidates = [(path.parent / m.group(1)).resolve(), (self.root / m.group(1)).resolve()]
                inside = [c for c in candidates if not self._outside(c)]
                if not inside:  # never read, compiled or watched: only files under the shader root are
                    raise _SourceError(ShaderError(self._rel(path), lineno, f'#include "{m.group(1)}" is outside '
                                                   f"the shader folder {self.root}: refused"))
                inc = next((c for c in inside if c.exists()), None)  # a FIFO or folder: read_regular_file says so
                if inc is None:
                    if watch is not None:
                        watch.update(inside)  # either appearing fixes it
                    raise _SourceError(ShaderError(self._rel(path), lineno, f'#include "{m.group(1)}" not found'))
                out.append(f"#line 1 {len(files) if inc not in files else files.index(inc)}")
                out.extend(self._expand(inc, files, stack + (path,), watch))
                if any(ln.strip() for ln in src_lines[lineno:]):  # NVIDIA refuses a #line that ends the source
                    out.append(f"#line {lineno + 1} {fid}")  # (C0115, an include on a file's last line)
            else:
                out.append(line)
                if line.lstrip().startswith("#version") and not stack:
                    out.append(f"#line {lineno + 1} {fid}")
        return out

    def _outside(self, p: Path) -> str:
        """Why ``p`` (symlinks resolved) may not be read, when it lies outside the shader root: a
        shader file can only ever pull in GLSL from the root, never /etc/passwd or ../secret."""
        root = self.root.resolve()
        try:
            real = Path(p).resolve()
        except (OSError, RuntimeError):  # a symlink loop
            return f"{p}: cannot resolve its path (a symlink loop?)"
        for r in (root, *(x.resolve() for x in self.include_roots)):
            if real == r or r in real.parents:
                return ""
        return f"{self._rel(Path(p))} is outside the shader folder {root} (symlinks resolved): refused"

    def _rel(self, p: Path) -> str:
        try:
            return str(p.relative_to(self.root))
        except ValueError:
            return str(p)

    def _stage_files(self, name: str) -> dict[str, Path]:
        found = {stage: self.root / f"{name}{ext}" for stage, ext in STAGES.items()}
        found = {s: p for s, p in found.items() if p.is_file()}
        if "fragment_shader" in found:  # a compute shader only where there is no fragment stage
            found.pop("compute_shader", None)
        elif "compute_shader" in found:
            return {"compute_shader": found["compute_shader"]}
        frag = found.get("fragment_shader")
        if frag is not None:
            try:
                m = _VERTEX_STAGE.search(read_regular_file(frag, MAX_SHADER_BYTES).decode("utf-8"))
            except (OSError, UnicodeDecodeError):
                m = None
            if m:
                found["vertex_shader"] = self.root / m.group(1)
        return found

    def _assemble(self, name: str, defines: tuple[tuple[str, str], ...], watch: set[Path] | None = None
                  ) -> tuple[dict[str, str], dict[str, list[Path]]]:
        if watch is not None:  # every stage file, present or not: a deleted one may come back
            root = self.root.resolve()  # the names themselves: a symlink out of the root is not followed
            watch.update(root / f"{name}{ext}" for ext in STAGES.values())
        stage_files = self._stage_files(name)
        if "fragment_shader" in stage_files and "vertex_shader" not in stage_files:
            self._expand(stage_files["fragment_shader"].resolve(), [])  # its own error (encoding) first
        if "compute_shader" not in stage_files and ("vertex_shader" not in stage_files
                                                    or "fragment_shader" not in stage_files):
            raise _SourceError(ShaderError(f"{name}.vert/.frag", 0, "shader files not found in " + str(self.root)))
        for stage, path in stage_files.items():
            outside = self._outside(path)
            if outside:
                raise _SourceError(ShaderError(f"{name}.frag" if stage == "vertex_shader" else self._rel(path), 0,
                                               ("#pragma vertex_stage: " if stage == "vertex_shader" else "")
                                               + outside))
        if "vertex_shader" in stage_files and not stage_files["vertex_shader"].is_file():
            raise _SourceError(ShaderError(f"{name}.frag", 0, "vertex stage "
                                           f"{self._rel(stage_files['vertex_shader'])} not found"))
        defines = tuple({**self.defines, **dict(defines)}.items())  # a program's own define wins
        sources: dict[str, str] = {}
        files_per_stage: dict[str, list[Path]] = {}
        for stage, path in stage_files.items():
            files: list[Path] = []
            lines = self._expand(path.resolve(), files, watch=watch)
            # an included file's #extension (e.g. lib/lights.glsl's) goes after #version, where GLSL
            # wants it (Mesa refuses one after code); its line stays as a comment: the numbers hold
            ext = list(dict.fromkeys(ln.strip() for ln in lines if _EXTENSION.match(ln)))
            lines = [("// " + ln.strip()) if _EXTENSION.match(ln) else ln for ln in lines]
            if defines or ext:
                at = next((i + 1 for i, ln in enumerate(lines) if ln.lstrip().startswith("#version")), 0)
                lines[at:at] = ext + [f"#define {k} {v}" for k, v in defines]  # the #line after #version follows
            sources[stage] = "\n".join(lines) + "\n"
            files_per_stage[stage] = files
        return sources, files_per_stage

    # -- compile -----------------------------------------------------------------------------
    def _compile(self, entry: _Entry) -> bool:
        watch: set[Path] = set()
        try:
            sources, files_per_stage = self._assemble(entry.name, entry.defines, watch)
        except _SourceError as exc:
            entry.errors = [exc.error]
            self._remember_files(entry, watch)
            return False
        all_files = {p for fs in files_per_stage.values() for p in fs}
        self._remember_files(entry, all_files | watch)
        digest = hashlib.sha1(repr(sorted(sources.items())).encode()).hexdigest()
        if entry.program is not None and digest == entry.digest:
            entry.errors = []
            return True
        try:
            if "compute_shader" in sources:  # a ComputeShader, held as the programs are (the same uniform
                # access by name, release); ExecuteContext.dispatch runs it
                prog = cast(moderngl.Program, self.ctx.compute_shader(sources["compute_shader"]))
            else:
                prog = self.ctx.program(vertex_shader=sources["vertex_shader"], fragment_shader=sources.get("fragment_shader"),
                                        geometry_shader=sources.get("geometry_shader"))
        except Exception as exc:  # moderngl.Error
            entry.errors = self._parse_errors(str(exc), files_per_stage)
            return False
        if entry.program is not None:
            self._by_program.pop(id(entry.program), None)
            for hook in list(self._release_hooks):
                hook(entry.program)
            entry.program.release()
        entry.program = prog
        entry.drawn = False
        entry.members = None
        self._by_program[id(prog)] = entry
        entry.declared = frozenset(n for src in sources.values() for n in declared_uniforms(src))
        entry.digest = digest
        entry.errors = []
        entry.generation += 1
        self.revision += 1
        return True

    def _remember_files(self, entry: _Entry, files: Iterable[Path]) -> None:
        entry.mtimes = {}
        for p in files:
            try:
                entry.mtimes[p] = p.stat().st_mtime_ns
            except OSError:
                entry.mtimes[p] = -1

    def _parse_errors(self, text: str, files_per_stage: dict[str, list[Path]]) -> list[ShaderError]:
        stage = next((s for s in files_per_stage if s.split("_")[0] in text.lower().split("\n", 3)[0].lower()), None)
        for s in files_per_stage:
            if s in text or s.replace("_", " ") in text.lower():
                stage = s
        files = (files_per_stage.get(stage) if stage else None) or next(iter(files_per_stage.values()))
        out = []
        for line in text.splitlines():
            for pat in _ERR_PATTERNS:
                m = pat.match(line)
                if m:
                    fid, ln, msg = int(m.group(1)), int(m.group(2)), m.group(3).strip()
                    f = self._rel(files[fid]) if 0 <= fid < len(files) else f"<source {fid}>"
                    out.append(ShaderError(f, ln, msg or line.strip()))
                    break
        if not out:
            first = text.strip().splitlines()
            out.append(ShaderError(self._rel(files[0]), 0, " ".join(first[:6]) if first else "compile failed"))
        # keep errors, drop warnings-only noise when there are errors
        errs = [e for e in out if "warning" not in e.message.lower()[:10]]
        return errs or out

    # -- public ------------------------------------------------------------------------------
    def _entry(self, name: str, defines: dict[str, Any] | None) -> _Entry:
        key_defs = tuple(sorted((str(k), str(v)) for k, v in (defines or {}).items()))
        key = (name, key_defs)
        entry = self._entries.get(key)
        if entry is None:
            entry = self._entries[key] = _Entry(name, key_defs)
            self._compile(entry)
        return entry

    def get(self, name: str, defines: dict[str, Any] | None = None) -> moderngl.Program:
        """The last good program; ShaderCompileError if it never compiled."""
        entry = self._entry(name, defines)
        if entry.program is None:
            raise ShaderCompileError(name, entry.errors)
        return entry.program

    def warm(self, items: Iterable[tuple[str, dict[str, Any] | None]], budget_ms: float | None = None) -> int:
        """Compile the variants ``items`` ((name, defines) pairs) not compiled yet, until
        ``budget_ms`` of wall time is spent (viewer idle frames, issue 14: a toggle then does not
        stall on a compile). Returns how many are still to compile. A driver that JIT-compiles at
        the first draw (llvmpipe) still pays that part then."""
        t0 = time.perf_counter()
        todo = [(n, d) for n, d in items
                if (n, tuple(sorted((str(k), str(v)) for k, v in (d or {}).items()))) not in self._entries]
        done = 0
        for name, defines in todo:
            if budget_ms is not None and done and (time.perf_counter() - t0) * 1000.0 > budget_ms:
                break
            self._entry(name, defines)
            done += 1
        return len(todo) - done

    def first_draw(self, prog: moderngl.Program) -> float | None:
        """Before a draw of ``prog``: the first one of a program this library made is counted
        (``first_draws``); when first draws are timed, returns the clock after a glFinish (hand it
        to ``first_draw_done`` after the draw), else None."""
        entry = self._by_program.get(id(prog))
        if entry is None or entry.program is not prog or entry.drawn:
            return None
        entry.drawn = True
        self.first_draws += 1
        if not self.time_first_draws:
            return None
        self.ctx.finish()
        return time.perf_counter()

    def first_draw_done(self, prog: moderngl.Program, t0: float | None) -> None:
        """After a first draw timed by ``first_draw``: its ms (sync: glFinish) logged and printed."""
        if t0 is None:
            return
        self.ctx.finish()
        ms = (time.perf_counter() - t0) * 1000.0
        entry = self._by_program.get(id(prog))
        name, defines = (entry.name, dict(entry.defines)) if entry is not None else ("?", {})
        self.first_draw_log.append((name, defines, ms))
        own = {k: v for k, v in defines.items() if self.defines.get(k) != v}
        print(f"first draw: {name} {own} {ms:.1f} ms", file=sys.stderr, flush=True)

    def members(self, prog: moderngl.Program) -> frozenset[str]:
        """The live uniform/attribute names of ``prog``, as ``name in prog`` tests them, made once per
        program this library made (moderngl's ``in`` walks every member: ~1,300 steps a d'Eon camera
        frame, issue 27's CPU overhead)."""
        entry = self._by_program.get(id(prog))
        if entry is None or entry.program is not prog:
            return frozenset(prog)
        if entry.members is None:
            entry.members = frozenset(prog)
        return entry.members

    def drawn(self, name: str, defines: dict[str, Any] | None = None) -> bool:
        """The variant is compiled and its running program has been drawn at least once."""
        key = (name, tuple(sorted((str(k), str(v)) for k, v in (defines or {}).items())))
        entry = self._entries.get(key)
        return entry is not None and entry.drawn

    def version(self, name: str, defines: dict[str, Any] | None = None) -> str:
        """Digest of the assembled source of the running program (part of pass cache keys)."""
        entry = self._entry(name, defines)
        return f"{entry.digest}:{entry.generation}"

    def describe(self, prog: moderngl.Program) -> tuple[str, frozenset[str]]:
        """(program name, uniform names declared in its GLSL source) of a program this library made."""
        entry = self._by_program.get(id(prog))
        if entry is None or entry.program is not prog:
            raise KeyError("program not made by this shader library")
        return entry.name, entry.declared

    def program_defines(self, prog: moderngl.Program) -> dict[str, str]:
        """The ``#define``s (as strings) a program this library made was compiled with; {} for another."""
        entry = self._by_program.get(id(prog))
        return dict(entry.defines) if entry is not None and entry.program is prog else {}

    def on_release(self, hook: Callable[[moderngl.Program], None]) -> None:
        """Call ``hook(program)`` just before a program is released (hot reload, release())."""
        self._release_hooks.append(hook)

    def remove_hook(self, hook: Callable[[moderngl.Program], None]) -> None:
        if hook in self._release_hooks:
            self._release_hooks.remove(hook)

    def errors(self) -> dict[str, list[ShaderError]]:
        return {e.name: list(e.errors) for e in self._entries.values() if e.errors}

    def changed(self) -> list[_Entry]:
        out = []
        for entry in self._entries.values():
            for p, t in entry.mtimes.items():
                try:
                    now = p.stat().st_mtime_ns
                except OSError:
                    now = -1
                if now != t:
                    out.append(entry)
                    break
        return out

    def reload(self, force: bool = False) -> tuple[list[str], dict[str, list[ShaderError]]]:
        """Recompile programs whose files changed (all when ``force``). Returns (names whose program
        was replaced, current errors per program). Programs that fail keep their last good version."""
        replaced = []
        todo = list(self._entries.values()) if force else self.changed()
        for entry in todo:
            gen = entry.generation
            self._compile(entry)
            if entry.generation != gen:
                replaced.append(entry.name)
        return replaced, self.errors()

    def release(self) -> None:
        for e in self._entries.values():
            if e.program is not None:
                for hook in list(self._release_hooks):
                    hook(e.program)
                e.program.release()
        self._entries.clear()
        self._by_program.clear()


def text_line(path: Path, offset: int) -> int:
    """1-based line of a byte offset in a file."""
    try:
        return path.read_bytes()[:offset].count(b"\n") + 1
    except OSError:
        return 0


class _SourceError(Exception):
    def __init__(self, error: ShaderError):
        self.error = error
