"""The render graph's GL memory (the resource cache of Filament's FrameGraph): one texture per resource
name, taken from the shared texture pool, with its spec and a version that bumps on every
(re)allocation (passes' cache keys read it); framebuffers per attachment set and depth buffers per size;
the memory a frame's plan needs, refused before anything is allocated (ResourceLimitError)."""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

import moderngl
import numpy as np

from skinviewer.kernel.pass_api import Reflection, ResourceLimitError, TexSpec
from skinviewer.kernel.texture_pool import TexturePool


class ResourceCache:
    """Textures by resource name, their specs and versions, framebuffers and depth buffers."""

    def __init__(self, ctx: moderngl.Context, pool: TexturePool):
        self.ctx = ctx
        self.pool = pool
        self.textures: dict[str, moderngl.Texture] = {}
        self.specs: dict[str, TexSpec] = {}
        self.versions: dict[str, int] = {}
        self.fbos: dict[tuple[tuple[moderngl.Texture, ...], bool], moderngl.Framebuffer] = {}
        self.depth: dict[tuple[int, int], moderngl.Renderbuffer] = {}
        # bytes of memory textures may take (None: no check); the Renderer sets it (RenderGraph.memory_available)
        self.memory_available: int | Callable[[], int] | None = None
        self._checked_plan: tuple[tuple[str, TexSpec], ...] | None = None

    # -- textures ----------------------------------------------------------------------------
    def take(self, spec: TexSpec) -> moderngl.Texture:
        """A scratch texture from the pool (not a named resource)."""
        return self.pool.take(spec)

    def give(self, tex: moderngl.Texture) -> None:
        """Back to the pool, with the framebuffers that attach it."""
        self.drop_fbos(tex)
        self.pool.give(tex)

    def drop_fbos(self, tex: moderngl.Texture) -> None:
        for key in [k for k in self.fbos if tex in k[0]]:
            self.fbos.pop(key).release()

    def ensure(self, resource: str, spec: TexSpec) -> bool:
        """Give ``resource`` a texture of ``spec``; True when it had to be (re)allocated."""
        held = self.specs.get(resource)
        if held is spec or held == spec:  # the same spec object while a reflection is kept
            return False
        self.free(resource)
        self.textures[resource] = self.pool.take(spec)
        self.specs[resource] = spec
        self.versions[resource] = self.versions.get(resource, 0) + 1
        return True

    def free(self, resource: str) -> None:
        tex = self.textures.pop(resource, None)
        if tex is not None:
            self.give(tex)
        self.specs.pop(resource, None)

    def read(self, resource: str) -> np.ndarray:
        """Read a texture back as float32 (H, W, C), row 0 at the bottom (GL order)."""
        tex = self.textures[resource]
        spec = self.specs[resource]
        w, h = spec.size
        if spec.dtype == "f1":
            raw = np.frombuffer(tex.read(alignment=1), dtype=np.uint8).astype(np.float32) / 255.0
        elif spec.dtype == "f2":
            raw = np.frombuffer(tex.read(), dtype=np.float16).astype(np.float32)
        else:
            raw = np.frombuffer(tex.read(), dtype=np.float32).copy()
        return raw.reshape(h, w, spec.components)

    # -- framebuffers ------------------------------------------------------------------------
    def framebuffer(self, resources: tuple[str, ...]) -> moderngl.Framebuffer:
        texs = tuple(self.textures[r] for r in resources)
        depth = any(self.specs[r].depth for r in resources)
        return self.framebuffer_for(texs, depth)

    def framebuffer_for(self, texs: tuple[moderngl.Texture, ...], depth: bool = False) -> moderngl.Framebuffer:
        key = (texs, depth)
        fbo = self.fbos.get(key)
        if fbo is None:
            size = texs[0].size
            rb = None
            if depth:
                rb = self.depth.get(size)
                if rb is None:
                    rb = self.depth[size] = self.ctx.depth_renderbuffer(size)
            fbo = self.fbos[key] = self.ctx.framebuffer(color_attachments=list(texs), depth_attachment=rb)
        return fbo

    def trim(self) -> None:
        """Release depth buffers no cached framebuffer uses (one is made per render size)."""
        used = {fbo.depth_attachment.glo for fbo in self.fbos.values() if fbo.depth_attachment is not None}
        for size in [s for s, rb in self.depth.items() if rb.glo not in used]:
            self.depth.pop(size).release()

    # -- memory ------------------------------------------------------------------------------
    @staticmethod
    def plan_bytes(refl: dict[str, Reflection], order: list[Any]) -> tuple[int, list[tuple[str, int]]]:
        """Memory the frame's textures take: every live output, a depth buffer per size that needs
        one, and ping-pong scratch (up to two copies of the largest pass's outputs)."""
        per_res: list[tuple[str, int]] = []
        depth_sizes: set[tuple[int, int]] = set()
        biggest_pass = 0
        for p in order:
            outs = refl[p.name].outputs
            biggest_pass = max(biggest_pass, sum(spec.nbytes for spec in outs.values()))
            for res, spec in outs.items():
                per_res.append((res, spec.nbytes))
                if spec.depth:
                    depth_sizes.add(spec.size)
        total = sum(b for _, b in per_res) + sum(w * h * 4 for w, h in depth_sizes) + 2 * biggest_pass
        return total, sorted(per_res, key=lambda x: -x[1])

    def check_memory(self, refl: dict[str, Reflection], order: list[Any]) -> None:
        """Refuse (ResourceLimitError) a frame whose textures will not fit, before allocating any."""
        budget = self.memory_available
        if budget is None:
            return
        plan = tuple((res, spec) for p in order for res, spec in refl[p.name].outputs.items())
        if plan == self._checked_plan or all(self.specs.get(res) == spec for res, spec in plan):
            return  # nothing new to allocate
        needed, per_res = self.plan_bytes(refl, order)
        held = sum(self.specs[r].nbytes for r in self.textures if r in self.specs)
        available = int(budget() if callable(budget) else budget) + held
        if needed > available:
            raise ResourceLimitError(needed, available, per_res)
        self._checked_plan = plan

    def release(self) -> None:
        """Every named texture back to the pool; framebuffers and depth buffers released."""
        for res in list(self.textures):
            self.free(res)
        for fbo in self.fbos.values():
            fbo.release()
        self.fbos.clear()
        for rb in self.depth.values():
            rb.release()
        self.depth.clear()
