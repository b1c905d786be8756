"""GL services a RenderGraph owns for its passes (used through ExecuteContext): the one cache of
vertex arrays (full-screen triangle and scene mesh per program), 1x1 dummy textures that back the
samplers a draw does not bind, and uniform writes by value type."""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import moderngl
import numpy as np

if TYPE_CHECKING:
    from skinviewer.kernel.gpu_scene import GpuScene

# sampler uniform types (GL enums) -> (components, dtype) of the 1x1 dummy texture backing them
_SAMPLER_KINDS = {
    0x8B5E: (4, "f1"),  # sampler2D
    0x8DCA: (4, "i4"),  # isampler2D
    0x8DD2: (4, "u4"),  # usampler2D
}
_OTHER_SAMPLERS = {0x8B5D, 0x8B5F, 0x8B60, 0x8B61, 0x8B62, 0x8B63, 0x8B64, 0x8DC0, 0x8DC1, 0x8DC4,
                   0x8DC5, 0x8DC9, 0x8DCB, 0x8DCC, 0x8DCE, 0x8DCF, 0x8DD1, 0x8DD3, 0x8DD4, 0x8DD6,
                   0x8DD7, 0x9108, 0x9109, 0x910A, 0x910B, 0x910C, 0x910D}


class GpuServices:
    """Per-graph GL objects made on behalf of passes, released when their program is replaced (hot
    reload: ShaderLibrary.on_release), when the scene changes (``keep_scene``) and on ``release``."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._vaos: dict[tuple[int, int, Any], tuple[moderngl.Program, object, moderngl.VertexArray]] = {}
        self._samplers: dict[int, tuple[moderngl.Program, dict[str, int]]] = {}
        self._dummies: dict[int, tuple[moderngl.Texture, int]] = {}
        # banded mesh draws: (scene, lod, space, matrix, rows) -> per triangle (min, max) window row
        self._band_rows: dict[tuple[Any, ...], np.ndarray] = {}
        self._band_ibos: dict[tuple[int, int], tuple[object, moderngl.Buffer]] = {}  # (scene, lod) -> index buffer
        self.max_units = int(ctx.info.get("GL_MAX_TEXTURE_IMAGE_UNITS", 16))
        self.binding_units = self.max_units - len(_SAMPLER_KINDS)  # the top units hold the dummies

    # -- vertex arrays -------------------------------------------------------------------------
    def _vao(self, prog: moderngl.Program, owner: object, make: Callable[[], moderngl.VertexArray],
             tag: int | tuple[str, int] | None = None) -> moderngl.VertexArray:
        key = (id(prog), id(owner), tag)
        hit = self._vaos.get(key)
        if hit is not None and hit[0] is prog and hit[1] is owner:
            return hit[2]
        if hit is not None:
            hit[2].release()  # an id reused by a new program or scene
        vao = make()
        self._vaos[key] = (prog, owner, vao)
        return vao

    def fullscreen_vao(self, prog: moderngl.Program) -> moderngl.VertexArray:
        """A VAO without buffers: the vertex stage makes a full-screen triangle from gl_VertexID."""
        return self._vao(prog, None, lambda: self.ctx.vertex_array(prog, []))

    def mesh_vao(self, prog: moderngl.Program, scene: GpuScene, lod: int = 0, env_rays: int = 0) -> moderngl.VertexArray:
        """The scene's mesh at level of detail ``lod`` (``scene.vertex_array(prog, lod)``) for ``prog``;
        ``env_rays``: the environment bake it binds (the program's ENV_RAYS, 0: none; one per program)."""
        if env_rays:
            return self._vao(prog, scene, lambda: scene.vertex_array(prog, lod, env_rays=env_rays), lod)
        return self._vao(prog, scene, lambda: scene.vertex_array(prog, lod), lod)

    def keep_scene(self, scene: GpuScene | None) -> None:
        """Release the mesh VAOs of every scene but ``scene`` (a new scene replaced the old one)."""
        for key in [k for k, (_, owner, _) in self._vaos.items() if owner is not None and owner is not scene]:
            self._vaos.pop(key)[2].release()
        for bkey in [k for k, (owner, _) in self._band_ibos.items() if owner is not scene]:
            self._band_ibos.pop(bkey)[1].release()
        for rkey in [k for k in self._band_rows if k[0] != id(scene)]:
            del self._band_rows[rkey]

    def band_vao(self, prog: moderngl.Program, scene: GpuScene, lod: int, space: str,
                 matrix: np.ndarray | None, rows: int, band: tuple[int, int],
                 env_rays: int = 0) -> tuple[moderngl.VertexArray, int]:
        """The mesh for one row band ``band`` = (y0, y1) of a target ``rows`` high (issue 27): a VAO
        whose index buffer holds, in their order, only the triangles whose window rows reach the
        band (so a pass in n bands does not transform the whole mesh n times), and its index count.
        ``space``: "camera" (clip = ``matrix`` x position, the view-mesh passes) or "uv" (the
        texture-space unwrap, y = v). Conservative: a triangle with a vertex behind the eye, or
        within BAND_MARGIN rows of the band, is drawn; the others have no fragment in the band,
        so the band's pixels are those of the whole draw, bit for bit."""
        ys = band_rows(scene, lod, space, matrix, rows, self._band_rows)
        y0, y1 = band
        tris = scene.lod_mesh(lod).indices
        keep = (ys[:, 1] >= y0 - BAND_MARGIN) & (ys[:, 0] <= y1 + BAND_MARGIN)
        data = np.ascontiguousarray(tris[keep], np.uint32)
        hit = self._band_ibos.get((id(scene), lod))
        if hit is None or hit[0] is not scene:
            if hit is not None:
                hit[1].release()
            hit = self._band_ibos[(id(scene), lod)] = (scene, self.ctx.buffer(reserve=max(tris.size * 4, 4)))
        buf = hit[1]
        buf.orphan()  # a new store: no wait for the draws still reading the last band's
        if data.size:
            buf.write(data.tobytes())
        if env_rays:
            vao = self._vao(prog, scene, lambda: scene.vertex_array(prog, lod, index_buffer=buf, env_rays=env_rays),
                            ("band", lod))
        else:
            vao = self._vao(prog, scene, lambda: scene.vertex_array(prog, lod, index_buffer=buf), ("band", lod))
        return vao, int(data.size)

    def forget_program(self, prog: moderngl.Program) -> None:
        """Release what was made for ``prog`` (called before the library releases it)."""
        for key in [k for k, (p, _, _) in self._vaos.items() if p is prog]:
            self._vaos.pop(key)[2].release()
        self._samplers.pop(id(prog), None)

    # -- samplers ------------------------------------------------------------------------------
    def samplers(self, prog: moderngl.Program) -> dict[str, int]:
        """The active sampler uniforms of ``prog``: name -> GL type."""
        hit = self._samplers.get(id(prog))
        if hit is None or hit[0] is not prog:
            found = {}
            for name in prog:
                u = prog[name]
                t = getattr(u, "gl_type", None)
                if isinstance(u, moderngl.Uniform) and (t in _SAMPLER_KINDS or t in _OTHER_SAMPLERS):
                    found[name] = t
            hit = self._samplers[id(prog)] = (prog, found)
        return hit[1]

    def dummy(self, gl_type: int) -> int:
        """The texture unit (from the top) holding a 1x1 zero texture for samplers of ``gl_type``."""
        hit = self._dummies.get(gl_type)
        if hit is None:
            if gl_type not in _SAMPLER_KINDS:
                raise ValueError(f"no dummy texture for sampler type 0x{gl_type:04X}")
            comps, dtype = _SAMPLER_KINDS[gl_type]
            tex = self.ctx.texture((1, 1), comps, bytes(comps * (1 if dtype == "f1" else 4)), dtype=dtype)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            hit = self._dummies[gl_type] = (tex, self.max_units - 1 - len(self._dummies))
        tex, unit = hit
        tex.use(unit)
        return unit

    def release(self) -> None:
        for _, _, vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        self._samplers.clear()
        for tex, _ in self._dummies.values():
            tex.release()
        self._dummies.clear()


BAND_MARGIN = 2.0  # rows: a triangle this close to a band is drawn in it (float rounding of the projection)


def band_rows(scene: GpuScene, lod: int, space: str, matrix: np.ndarray | None, rows: int,
              cache: dict[tuple[Any, ...], np.ndarray]) -> np.ndarray:
    """(T, 2) the lowest and highest window row each triangle of ``scene``'s mesh at ``lod`` covers
    in a target ``rows`` high (-inf/inf: a vertex behind the eye, it may cover any row)."""
    key = (id(scene), lod, space, None if matrix is None else np.asarray(matrix, np.float32).tobytes(), rows)
    hit = cache.get(key)
    if hit is not None:
        return hit
    m = scene.lod_mesh(lod)
    if space == "uv":
        y = np.asarray(m.uvs, np.float64)[:, 1] * rows  # unwrap.vert: gl_Position.y = 2 v - 1
        ok = None
    else:
        p = np.asarray(m.positions, np.float64)
        mat = np.asarray(matrix, np.float64)
        clip_y = p @ mat[1, :3] + mat[1, 3]  # only y and w of the clip position are needed
        w = p @ mat[3, :3] + float(mat[3, 3])
        ok = w > 1e-6
        y = (clip_y / np.where(ok, w, 1.0) * 0.5 + 0.5) * rows
    # per corner, not a (T, 3) gather reduced along its rows: the same values, ~4x faster (issue 27:
    # 24-29 ms a view on the default head at load ~7, in the first band of every banded view pass)
    t = np.asarray(m.indices)
    a, b, c = y[t[:, 0]], y[t[:, 1]], y[t[:, 2]]
    out = np.stack([np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)], axis=1)
    if ok is not None:
        out[~(ok[t[:, 0]] & ok[t[:, 1]] & ok[t[:, 2]])] = (-np.inf, np.inf)
    if len(cache) > 16:
        cache.clear()
    cache[key] = out
    return out


def write_uniform(u: Any, value: Any) -> None:
    """Write ``value`` into uniform ``u``: bytes as they are; a numpy array as the uniform's element
    type, cut to the elements the compiler kept (an array whose tail is unused is shortened);
    anything else (number, bool, tuple) through ``.value``."""
    if isinstance(value, (bytes, bytearray)):
        u.write(value)
        return
    if isinstance(value, np.ndarray):
        fmt = u.fmt
        comps = int(fmt[:-1] or 1)
        dtype = {"i": np.int32, "I": np.uint32, "f": np.float32, "d": np.float64}[fmt[-1]]
        flat = np.ascontiguousarray(value, dtype=dtype).reshape(-1)
        need = u.array_length * comps
        if flat.size < need:
            raise ValueError(f"uniform {u.name}: {flat.size} values for {need}")
        u.write(flat[:need].tobytes())
        return
    if isinstance(value, (bool, np.bool_)):
        value = int(value)
    elif isinstance(value, np.generic):
        value = value.item()
    u.value = value
