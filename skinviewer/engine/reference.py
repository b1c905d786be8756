"""The ground-truth image of a Settings: the same lights, albedo, normal map, specular (Kelemen /
Szirmay-Kalos, seed 000 eq. 14-16), energy conservation (rho_dt, eq. 30-32), pre/post-scatter mix
(eq. 28, 34) and diffusion profile (deon.gaussians, eq. 21) as the techniques, with the diffusion
computed by brute force over the 3D surface (skinviewer.physics.ground_truth) and every visibility
test done by ray casting on Embree (trimesh + embreex): no shadow map, no texture space, no UVs
except to look up the surface's own maps.

- Visible surface: one camera ray through each pixel centre (the rasteriser's sample point).
- Irradiance E(y) A(y) = sum_lights Lc (N.L) vis rho_dt(N.L) C^mix (eq. 28, 32) at 3 points of each
  source element (sub-triangles of edge <= h mm), with its own shadow ray per light; the ray starts
  on the smooth (Phong-interpolated) surface (Hanika 2021's terminator fix) so faceting does not
  shadow the terminator. Beams (the laser) are K rays, each a point source of its power.
- Exitant diffuse M(x) of physics.ground_truth; thin parts: a lit back surface reaches x through
  the 3D distance (G(v, sqrt(r^2 + d^2)) for a flap of thickness d), which is the light the
  techniques' translucent shadow maps approximate (eq. 33).
- Pixel = C^(1-mix) rho_dt(N.V) M(x) + sum_lights Lc KS(N, L, V) vis  (eq. 34, 35).
- An environment light (issue 32): its irradiance int L(w) V(w) (N.w) rho_dt(N.w) dw as the exact
  unoccluded sum over the environment's texels less the blocked light, estimated by Monte Carlo with
  multiple importance sampling (cosine and environment directions, stratified) and Embree visibility
  (ENV_DIFFUSE_RAYS per point; no SH, no baked AO) at three points inside each source triangle, linear
  between them (each block of points seeded by its ids, version 7); its
  specular int L(w) KS(N, w, V) V(w) dw by stratified Beckmann importance sampling (ENV_SPEC_RAYS per
  pixel). meta["env"] holds the standard errors (from independent batches); the uncertainty states
  their effect on the image (env_mc_uncertainty, version 8; Reference.uncertainty_env).

Results are cached on disk (``cache_dir()/reference``) by a hash of everything they depend on.
"""
from __future__ import annotations

import functools
import hashlib
import io
import json
import math
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.ground.files import atomic_write_bytes
from skinviewer.ground.paths import cache_dir
from skinviewer.ground.settings import REGIONS, LightSettings, Settings
from skinviewer.passes.rules import environment_light
from skinviewer.physics import ground_truth as gt
from skinviewer.physics.color import srgb_to_linear
from skinviewer.physics.environment import EnvSampler
from skinviewer.physics.specular import (
    beckmann_lut,
    ks_specular,
    ks_specular_lut,
    per_region_specular,
    rho_dt_table,
    sample_bilinear,
)
from skinviewer.scene.camera import framed_view
from skinviewer.scene.environment import environment_image
from skinviewer.scene.mesh import MeshData, culls_back_faces, is_closed, load_mesh, load_texture_maps
from skinviewer.scene.scenes import build_scene

VERSION = 10                # bump when the reference's maths or its inputs change (invalidates the cache): 4, seam normals; 5, shadow edges cut; 6, environments; 7, environment's samples seeded per block of points; 8, the uncertainty states the environment's Monte Carlo error; 9, and its interpolation inside the triangles; 10, that interpolation's checks weighted by what each Gaussian reads
VERSION_CHANGE = "its uncertainty now weights the environment's interpolation checks by what each Gaussian reads"  # what VERSION changed, for the stale cache's note
ENV_DIFFUSE_RAYS = 256      # per point of each source triangle (4 independent stratified batches)
ENV_SPEC_RAYS = 64          # per pixel
ENV_BATCHES = 4
ENV_TARGET = 0.004          # adaptive sampling's goal: standard error / max(irradiance, its median)
ENV_SAMPLER_WIDTH = 128     # the irradiance's environment, box-filtered (0.03 % from the full image's irradiance)
ENV_COARSE_RAYS = 32        # per vertex for the progressive truth's first figure (no adaptive rays)
ENV_COARSE_SPEC_RAYS = 16   # per pixel, the first figure's environment specular
# the three points of a source triangle the environment's (full) irradiance is estimated at, and the map
# from a point's barycentrics to the linear interpolation weights of those three
_ENV_B = np.array([[4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]]) / 6.0
_ENV_W = np.linalg.inv(_ENV_B)
ENV_LEVELS = ("full", "coarse")
ENV_COARSE_SAMPLER_WIDTH = 64  # the coarse level's environment, box-filtered: its exact unoccluded sum 4-6x cheaper (p99 1 % off)
ENV_BLOCK = 1536            # estimation point ids estimated together, with a seed of their own
ProfileArrays = tuple[np.ndarray, np.ndarray]  # (variances (k,), weights (k, 3)) of a sum of Gaussians
DEFAULT_H_MM = 0.5          # source element edge

BEAM_RAYS = 64
DEFAULT_SKIN_SRGB = (0.80, 0.62, 0.53)  # as kernel.gpu_scene: a mesh without an albedo map
RHO_DT_SIZE = (32, 32)      # the table the techniques sample (passes/rho_dt.py)


class ReferenceTooSlow(RuntimeError):
    """The estimated time exceeds the limit the caller set."""


@dataclass
class Reference:
    """Linear images (H, W, 3), top row first, and the mask of pixels that hit the mesh."""
    lit: np.ndarray
    diffuse: np.ndarray
    specular: np.ndarray
    mask: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)
    position: np.ndarray | None = None  # (H, W, 3) surface point of each pixel, mesh units
    uncertainty: np.ndarray | None = None  # (H, W, 3) of ``lit``: |M_h - M_2h| (see coarse_uncertainty)
    uncertainty_env: np.ndarray | None = None  # (H, W, 3): the environment's Monte Carlo part of ``uncertainty``


# -- scene -------------------------------------------------------------------------------------

def load_scene(s: Settings) -> tuple[MeshData, float]:
    """The mesh and its mm per unit, as Renderer.ensure_scene loads them (without GL)."""
    sc = s.scene
    if sc.mesh:
        mesh = load_mesh(sc.mesh)
        mm = sc.mm_per_unit if sc.mm_per_unit is not None else 1.0
    else:
        mesh = build_scene(sc.name, sc.head_detail).mesh
        mm = sc.mm_per_unit if sc.mm_per_unit is not None else mesh.mm_per_unit
    return load_texture_maps(mesh, sc.albedo_map, sc.normal_map, sc.specular_map, sc.region_map), float(mm)


def _tex(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear, clamp-to-edge lookup of an (H, W, C) map (row 0 at v = 0) at uv (N, 2) -> (N, C)."""
    img = np.asarray(img, np.float64)
    if img.ndim == 2:
        img = img[..., None]
    return np.stack([sample_bilinear(img[..., c], uv[:, 0], uv[:, 1]) for c in range(img.shape[2])], 1)


class Surface:
    """The mesh with its maps, for shading arbitrary points (triangle id, barycentrics)."""

    def __init__(self, mesh: MeshData, mm: float, s: Settings):
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        self.mesh, self.mm, self.s = mesh, mm, s
        self.P = mesh.positions.astype(np.float64)
        self.F = mesh.indices.astype(np.int64)
        self.Nv = mesh.normals.astype(np.float64)
        self.UV = mesh.uvs.astype(np.float64)
        assert mesh.tangents is not None, "GpuScene-ready meshes carry tangents"
        self.T = mesh.tangents.astype(np.float64)
        tri = self.P[self.F]
        fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        self.Ng = fn / np.maximum(np.linalg.norm(fn, axis=1), 1e-300)[:, None]
        self.radius = float(mesh.radius)
        self.center = mesh.center.astype(np.float64)
        self.frame = mesh.frame  # what the camera frames (the head of a bust), as the renderer does
        self.eps = 1e-5 * self.radius + 1e-6
        self.cull_back = culls_back_faces(s.scene.back_faces, is_closed(self.P, self.F))
        self.rays = RayMeshIntersector(trimesh.Trimesh(self.P, self.F, process=False))
        albedo = mesh.albedo if mesh.albedo is not None else np.ones((1, 1, 3)) * np.asarray(DEFAULT_SKIN_SRGB)
        self.albedo = srgb_to_linear(np.nan_to_num(np.asarray(albedo, np.float64), nan=0.0))
        self.normal_map = mesh.normal_map
        self.spec_map = mesh.specular_map if mesh.specular_map is not None else np.ones((1, 1, 1))
        self.region = mesh.region_map if mesh.region_map is not None else np.zeros((1, 1), np.uint8)
        self.m_reg, self.rho_reg = per_region_specular(s.specular)
        sp = s.specular
        self.rho_table = np.nan_to_num(np.clip(rho_dt_table(sp.f0, sp.rho_s, *RHO_DT_SIZE), 0, 1), nan=1.0)
        self.beckmann = beckmann_lut(sp.lut_size) if sp.mode == "beckmann_lut" else None
        self.lights = [l for l in s.lights[:4] if l.enabled and l.kind != "environment"]
        hit = environment_light(s.lights)
        self.env = None
        if hit is not None:
            e = hit[1]
            self.env = e
            self.env_img = np.asarray(environment_image(e.environment, e.layout), np.float64) * \
                (np.asarray(e.color, np.float64) * e.intensity)[None, None]
            self.env_rng = np.random.default_rng(12345)
            self.env_sampler = EnvSampler(self.env_img, e.yaw, ENV_SAMPLER_WIDTH)
            self.env_sampler_coarse = EnvSampler(self.env_img, e.yaw, ENV_COARSE_SAMPLER_WIDTH)
            # the environment's irradiance, Monte Carlo at points of the surface, linear between them, per
            # level: "full" at three points inside each triangle (_ENV_B; ENV_DIFFUSE_RAYS, adaptive) and
            # "coarse" at the mesh's vertices (a vertex is shared by ~6 triangles: 6x fewer points;
            # ENV_COARSE_RAYS, the first figure's; issue 34)
            V, T = len(self.P), len(self.F)
            npts = {"full": 3 * T, "coarse": V}
            self.env_val = {lv: np.zeros((npts[lv], 3)) for lv in ENV_LEVELS}
            self.env_err = {lv: np.zeros((npts[lv], 3)) for lv in ENV_LEVELS}
            self.env_done = {lv: np.zeros(npts[lv], bool) for lv in ENV_LEVELS}
            # a vertex's point: one triangle holding it and its corner; shadow rays leave along the
            # area-weighted face normal there (both sides of a ridge see the same origin)
            vt = np.full(V, -1, np.int64)
            vc = np.zeros(V, np.int64)
            for k in (2, 1, 0):
                vt[self.F[:, k]] = np.arange(T)
                vc[self.F[:, k]] = k
            self.env_used = {"full": np.ones(3 * T, bool), "coarse": vt >= 0}
            self.env_vt, self.env_vc = np.where(vt >= 0, vt, 0), vc
            ngv = np.zeros((V, 3))
            for k in range(3):
                np.add.at(ngv, self.F[:, k], fn)
            self.env_ngv = ngv / np.maximum(np.linalg.norm(ngv, axis=1), 1e-300)[:, None]
            self.env_spec_err: np.ndarray | None = None
            self.env_rays_used = 0.0
            self.env_points_done = 0

    # per-point attributes
    def attributes(self, tri: np.ndarray, bary: np.ndarray) -> dict[str, Any]:
        f = self.F[tri]
        P = np.einsum("nk,nkd->nd", bary, self.P[f])
        nv = np.einsum("nk,nkd->nd", bary, self.Nv[f])
        nv /= np.maximum(np.linalg.norm(nv, axis=1), 1e-300)[:, None]
        uv = np.einsum("nk,nkd->nd", bary, self.UV[f])
        t = np.einsum("nk,nkd->nd", bary, self.T[f])
        N = self._shading_normal(nv, t, uv)
        C = np.maximum(_tex(self.albedo, uv), 0.0)
        m, rho = self._spec_params(uv)
        # Hanika 2021: lift P onto the tangent planes of the corners (outwards only)
        lift = np.zeros_like(P)
        for k in range(3):
            pk, nk = self.P[f[:, k]], self.Nv[f[:, k]]
            d = np.minimum(((P - pk) * nk).sum(1), 0.0)
            lift += bary[:, k:k + 1] * (-d[:, None] * nk)
        return {"P": P, "Ps": P + lift, "Ng": self.Ng[tri], "Nv": nv, "N": N, "uv": uv, "C": C, "m": m, "rho": rho,
                "tri": tri, "bary": bary}

    def _shading_normal(self, n: np.ndarray, t: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """shaders/lib/surface.glsl surface_normal."""
        if self.normal_map is None:
            return n
        T = t[:, :3] - n * (n * t[:, :3]).sum(1, keepdims=True)
        tl = np.linalg.norm(T, axis=1)
        ok = tl >= 1e-6
        T = T / np.where(ok, tl, 1.0)[:, None]
        B = np.cross(n, T) * np.where(t[:, 3] < 0, -1.0, 1.0)[:, None]
        mm = _tex(self.normal_map, uv) * 2.0 - 1.0
        P = T * mm[:, :1] + B * mm[:, 1:2] + n * mm[:, 2:3]
        pl = np.linalg.norm(P, axis=1)
        good = ok & (pl > 1e-6)
        return np.where(good[:, None], P / np.where(good, pl, 1.0)[:, None], n)

    def _spec_params(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """shaders/lib/specular_params.glsl: region parameters blended over 4 texels, rho_s x map."""
        h, w = self.region.shape[:2]
        st = uv * np.array([w, h]) - 0.5
        i0 = np.floor(st).astype(np.int64)
        f = np.clip(st - i0, 0.0, 1.0)
        m = np.zeros(len(uv))
        rho = np.zeros(len(uv))
        for ox, oy in ((0, 0), (1, 0), (0, 1), (1, 1)):
            ix = np.clip(i0[:, 0] + ox, 0, w - 1)
            iy = np.clip(i0[:, 1] + oy, 0, h - 1)
            rid = self.region[iy, ix].astype(np.int64)
            rid = np.where((rid < 0) | (rid >= len(REGIONS)), 0, rid)
            wt = (f[:, 0] if ox else 1 - f[:, 0]) * (f[:, 1] if oy else 1 - f[:, 1])
            m += wt * self.m_reg[rid]
            rho += wt * self.rho_reg[rid]
        scale = _tex(self.spec_map, uv)[:, 0]
        scale = np.where(np.isfinite(scale), np.clip(scale, 0, 10), 1.0)
        return m, rho * scale

    def rho_dt(self, cos_theta: ArrayLike, m: ArrayLike, rho_s: ArrayLike) -> np.ndarray:
        """surface_rho_dt: the table for specular.rho_s rescaled to the point's rho_s."""
        t = np.clip(sample_bilinear(self.rho_table, np.clip(cos_theta, 0, 1), np.clip(m, 0, 1)), 0, 1)
        r0 = self.s.specular.rho_s
        if not r0 > 0:
            return np.ones_like(t)
        return np.clip(1.0 - (1.0 - t) * np.asarray(rho_s, np.float64) / r0, 0.0, 1.0)

    def rho_dt_rows(self, m: np.ndarray) -> np.ndarray:
        """(N, n_cos) the rho_dt table interpolated to each point's m at the table's cos columns: with
        rho_dt_along, Surface.rho_dt for many N.L per point at the cost of a 1-D lookup."""
        n_cos = self.rho_table.shape[1]
        xs = (np.arange(n_cos) + 0.5) / n_cos
        return sample_bilinear(self.rho_table, np.broadcast_to(xs[None], (len(m), n_cos)),
                               np.broadcast_to(np.clip(m, 0, 1)[:, None], (len(m), n_cos)))

    def rho_dt_along(self, rows: np.ndarray, rho_s: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
        """Surface.rho_dt at cos_theta (N, K) for the points of ``rows`` (rho_dt_rows) and their rho_s."""
        n_cos = rows.shape[1]
        # one clip does both of sample_bilinear's (cos in [0, 1], then the texel centres); the rows are
        # in [0, 1] already (rho_table is clipped), so their interpolation is too
        pos = np.clip(np.asarray(cos_theta, np.float64) * n_cos - 0.5, 0.0, n_cos - 1.0)
        i0 = pos.astype(np.int64)
        f = pos - i0
        flat = np.ascontiguousarray(rows, np.float64).ravel()
        i0 += (np.arange(len(rows)) * n_cos)[:, None]
        lo = flat[i0]
        hi = flat[np.minimum(i0 + 1, len(flat) - 1)]
        t = lo + (hi - lo) * f  # f = 0 at the last column: hi (the next row's first entry) has no weight
        r0 = self.s.specular.rho_s
        if not r0 > 0:
            return np.ones_like(t)
        out: np.ndarray = np.clip(1.0 - (1.0 - t) * np.asarray(rho_s)[:, None] / r0, 0.0, 1.0)
        return out

    def light_dir(self, light: LightSettings, P: np.ndarray) -> np.ndarray:
        if light.kind == "point":
            d = np.asarray(light.position, np.float64) - P
            unit: np.ndarray = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
            return unit
        d = np.asarray(light.direction, np.float64)

        out: np.ndarray = np.broadcast_to(d / np.linalg.norm(d), P.shape)
        return out

    def visible(self, light: LightSettings, a: dict[str, Any], L: np.ndarray) -> np.ndarray:
        """Shadow ray from the lifted point towards the light (hard, exact)."""
        if not light.cast_shadow or len(L) == 0:
            return np.ones(len(L), bool)
        ng = a["Ng"] * np.where((a["Ng"] * L).sum(1) >= 0, 1.0, -1.0)[:, None]
        o = a["Ps"] + ng * self.eps
        if light.kind == "point":
            _, idx_ray, loc = self.rays.intersects_id(o, L, multiple_hits=False, return_locations=True)
            dl = np.linalg.norm(np.asarray(light.position) - o, axis=1)
            hit = np.zeros(len(L), bool)
            dh = np.linalg.norm(loc - o[idx_ray], axis=1)
            hit[idx_ray[dh < dl[idx_ray]]] = True
            return ~hit
        out: np.ndarray = ~self.rays.intersects_any(o, np.ascontiguousarray(L))
        return out

    def irradiance(self, a: dict[str, Any], mix: float, energy: bool, env_level: str = "full") -> np.ndarray:
        """E A (eq. 28, 32) from the directional and point lights (beams are point sources) and the
        environment (issue 32: its occluded irradiance, Monte Carlo; ``env_level`` as env_irradiance)."""
        U, vis = self.irradiance_parts(a, mix, energy)
        E = (U * vis[..., None]).sum(0) if len(U) else np.zeros((len(a["P"]), 3))
        if self.env is not None and env_level != "none":  # "none": without the environment
            E = E + self.env_irradiance(a["tri"], a["bary"], energy, env_level) * _safe_pow(a["C"], mix)
        return E

    def shadow_lights(self) -> list[LightSettings]:
        """The directional and point lights, in the order of irradiance_parts."""
        return [l for l in self.lights if l.kind != "beam"]

    def irradiance_parts(self, a: dict[str, Any], mix: float, energy: bool) -> tuple[np.ndarray, np.ndarray]:
        """Per light of shadow_lights(): the unshadowed E A, Lc (N.L)+ rho_dt(N.L) C^mix (L, N, 3), and
        the visibility (L, N) (True where N.L <= 0: nothing to shadow there), so E A = sum U vis."""
        lights = self.shadow_lights()
        n = len(a["P"])
        U = np.zeros((len(lights), n, 3))
        vis = np.ones((len(lights), n), bool)
        cmix = _safe_pow(a["C"], mix)
        for li, light in enumerate(lights):
            L = self.light_dir(light, a["P"])
            ndl = (a["N"] * L).sum(1)
            lit = ndl > 0
            if not lit.any():
                continue
            sub = {k: v[lit] for k, v in a.items()}
            vis[li, lit] = self.visible(light, sub, np.ascontiguousarray(L[lit]))
            rho = self.rho_dt(ndl[lit], sub["m"], sub["rho"]) if energy else 1.0
            Lc = np.asarray(light.color, np.float64) * light.intensity
            U[li, lit] = Lc[None] * (ndl[lit] * rho)[:, None] * cmix[lit]
        return U, vis

    def visibility_at(self, li: int, tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
        """Light li's visibility (as irradiance_parts: True where N.L <= 0) at (triangle, barycentrics)."""
        light = self.shadow_lights()[li]
        a = self.attributes(tri, bary)
        L = self.light_dir(light, a["P"])
        out = np.ones(len(tri), bool)
        lit = (a["N"] * L).sum(1) > 0
        if lit.any():
            out[lit] = self.visible(light, {k: v[lit] for k, v in a.items()}, np.ascontiguousarray(L[lit]))
        return out

    # -- the environment light (issue 32) ------------------------------------------------------------
    def _env_points(self, level: str, ids: np.ndarray) -> dict[str, Any]:
        """The attributes of the environment's estimation points ``ids`` of ``level``."""
        if level == "full":
            t = ids // 3
            a = self.attributes(t, _ENV_B[ids % 3])
        else:
            bary = np.zeros((len(ids), 3))
            bary[np.arange(len(ids)), self.env_vc[ids]] = 1.0
            a = self.attributes(self.env_vt[ids], bary)
            a["Ng"] = self.env_ngv[ids]
        return a

    def _env_support(self, level: str, tri: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The estimation points (N, 3) around points (tri, bary) and their linear weights (N, 3)."""
        if level == "full":
            return 3 * tri[:, None] + np.arange(3)[None], bary @ _ENV_W
        return self.F[tri], bary

    def _env_estimate(self, ids: np.ndarray, energy: bool, level: str = "full") -> None:
        """Monte Carlo irradiance at the estimation points ``ids`` of ``level`` ("full": ENV_DIFFUSE_RAYS,
        adaptive; "coarse": ENV_COARSE_RAYS against a coarser environment, for the first figure)."""
        from skinviewer.physics.environment import mc_irradiance_cv
        if len(ids) == 0:
            return
        a = self._env_points(level, ids)
        weight = None
        if energy:
            rows, rho = self.rho_dt_rows(a["m"]), a["rho"]

            def weight(mu: np.ndarray, sl: slice | np.ndarray) -> np.ndarray:
                return self.rho_dt_along(rows[sl], rho[sl], mu)
        n_rays = ENV_DIFFUSE_RAYS if level == "full" else ENV_COARSE_RAYS
        sampler = self.env_sampler if level == "full" else self.env_sampler_coarse
        est, err = mc_irradiance_cv(sampler, a["Ps"], a["N"], a["Ng"], self.rays, n_rays,
                                    self.env_rng, self.eps, weight=weight, batches=ENV_BATCHES)
        # adaptive: points whose standard error exceeds ENV_TARGET of max(their irradiance, the median's)
        # (the occluded ones: folds, ears) get 4x the rays more, combined by ray count
        rays = np.full(len(est), float(n_rays))
        scale = max(float(np.median(est.sum(1))), 1e-300)
        for more in ((4,) if level == "full" else ()):
            bad = np.nonzero(np.sqrt((err ** 2).sum(1)) > ENV_TARGET * np.maximum(est.sum(1), scale))[0]
            if len(bad) == 0:
                break
            sub = {k: v[bad] for k, v in a.items()}

            def w_sub(mu: np.ndarray, sl: slice, _bad: np.ndarray = bad) -> ArrayLike:
                return weight(mu, _bad[sl]) if weight is not None else 1.0
            e2, s2 = mc_irradiance_cv(self.env_sampler, sub["Ps"], sub["N"], sub["Ng"], self.rays,
                                      ENV_DIFFUSE_RAYS * more, self.env_rng, self.eps,
                                      weight=w_sub if weight is not None else None, batches=ENV_BATCHES)
            n1, n2 = rays[bad][:, None], float(ENV_DIFFUSE_RAYS * more)
            est[bad] = (n1 * est[bad] + n2 * e2) / (n1 + n2)
            err[bad] = np.sqrt(n1 ** 2 * err[bad] ** 2 + n2 ** 2 * s2 ** 2) / (n1 + n2)
            rays[bad] += n2
        if level == "full":
            self.env_rays_used += float(rays.sum())
            self.env_points_done += len(ids)
        self.env_val[level][ids] = est
        self.env_err[level][ids] = err
        self.env_done[level][ids] = True

    def env_more_rays(self, tri: np.ndarray, energy: bool, factor: int) -> None:
        """The full level's estimates of the triangles ``tri`` with ``factor`` x ENV_DIFFUSE_RAYS more rays,
        combined with what they have by ray count (refine_at: where a comparison's tail reads them);
        seeded by the triangles asked for. A triangle asked again with a larger factor gets the rays
        that bring it to that factor; with the same or a smaller one, nothing (the same rays again)."""
        if self.env is None:
            return
        boosted = self.__dict__.setdefault("env_boosted", np.zeros(len(self.F), np.int64))
        tri = np.unique(np.asarray(tri, np.int64))
        tri = tri[boosted[tri] < int(factor)]  # a triangle boosted to this factor already keeps its rays
        if len(tri) == 0:
            return
        self.env_irradiance(tri, np.full((len(tri), 3), 1.0 / 3.0), energy)  # the first estimates
        # what each triangle has (ENV_DIFFUSE_RAYS x (1 + its earlier factor)), in groups of one earlier factor
        for before in np.unique(boosted[tri]):
            self._env_boost(tri[boosted[tri] == before], energy, int(before), int(factor))
        boosted[tri] = int(factor)

    def _env_boost(self, tri: np.ndarray, energy: bool, before: int, factor: int) -> None:
        """env_more_rays for triangles boosted to ``before`` so far: (factor - before) x ENV_DIFFUSE_RAYS
        more rays, seeded by the triangles and the factors."""
        from skinviewer.physics.environment import mc_irradiance_cv
        ids = (3 * tri[:, None] + np.arange(3)[None]).ravel()
        a = self._env_points("full", ids)
        weight = None
        if energy:
            rows, rho = self.rho_dt_rows(a["m"]), a["rho"]

            def weight(mu: np.ndarray, sl: slice | np.ndarray) -> np.ndarray:
                return self.rho_dt_along(rows[sl], rho[sl], mu)
        n2 = float(ENV_DIFFUSE_RAYS * (int(factor) - int(before)))
        seed = (12345, 99, len(ids), int(ids.sum() % (2 ** 31))) + ((int(before), int(factor)) if before else ())
        rng = np.random.default_rng(seed)
        est, err = mc_irradiance_cv(self.env_sampler, a["Ps"], a["N"], a["Ng"], self.rays, int(n2), rng, self.eps,
                                    weight=weight, batches=ENV_BATCHES)
        # at least: the adaptive points had more (counted as this: conservative)
        n1 = float(ENV_DIFFUSE_RAYS * (1 + int(before)))
        v, e = self.env_val["full"], self.env_err["full"]
        v[ids] = (n1 * v[ids] + n2 * est) / (n1 + n2)
        e[ids] = np.sqrt(n1 ** 2 * e[ids] ** 2 + n2 ** 2 * err ** 2) / (n1 + n2)

    def env_stderr(self, tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
        """The standard error (N, 3) of env_irradiance's full level at (tri, bary): its three estimates'
        errors through the interpolation weights (independent estimates)."""
        ids, w = self._env_support("full", tri, bary)
        out: np.ndarray = np.sqrt(np.einsum("nk,nkc->nc", w ** 2, self.env_err["full"][ids] ** 2))
        return out

    def env_irradiance(self, tri: np.ndarray, bary: np.ndarray, energy: bool, level: str = "full") -> np.ndarray:
        """The environment's occluded irradiance (x rho_dt with ``energy``) at points (tri, bary): linear
        between its Monte Carlo estimates (``level`` "full": three points inside the triangle; "coarse":
        its vertices, unless the full estimate is there already)."""
        if level == "coarse" and self.env_done["full"][3 * tri[:, None] + np.arange(3)[None]].all():
            level = "full"
        ids, w = self._env_support(level, tri, bary)
        done = self.env_done[level]
        # whole blocks of ENV_BLOCK point ids, each with a seed of its own: a point's estimate is the same
        # whichever view or stage asked for it first (an orbit's truth equals a fresh session's)
        for blk in np.unique(ids[~done[ids]] // ENV_BLOCK):
            todo = np.arange(blk * ENV_BLOCK, min((blk + 1) * ENV_BLOCK, len(done)))
            todo = todo[self.env_used[level][todo] & ~done[todo]]
            self.env_rng = np.random.default_rng((12345, int(blk), ENV_LEVELS.index(level)))
            self._env_estimate(todo, energy, level)
        out: np.ndarray = np.einsum("nk,nkc->nc", w, self.env_val[level][ids])
        return out

    def env_direct(self, a: dict[str, Any], energy: bool, rays: int = ENV_DIFFUSE_RAYS, seed: int = 0
                   ) -> tuple[np.ndarray, np.ndarray]:
        """The environment's occluded irradiance (x rho_dt with ``energy``) estimated at the points of
        ``a`` themselves, not interpolated between estimation points (issue 34: the pixels' own E A;
        over ~2.8 mm triangles the interpolation is 2-3 % RMS off, up to the whole value at a fold):
        (estimate, standard error), (N, 3); ``rays`` per point, 4x more where the standard error
        exceeds ENV_TARGET as the surface's own estimates; seeded by ``seed``."""
        from skinviewer.physics.environment import mc_irradiance_cv
        rng = np.random.default_rng((777, int(seed)))
        rows = self.rho_dt_rows(a["m"]) if energy else None
        rho: np.ndarray = np.asarray(a["rho"])

        def run(idx: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
            w = None
            if rows is not None:
                r_idx, rho_idx = rows[idx], rho[idx]

                def w(mu: np.ndarray, sl: slice | np.ndarray) -> np.ndarray:
                    return self.rho_dt_along(r_idx[sl], rho_idx[sl], mu)
            return mc_irradiance_cv(self.env_sampler, a["Ps"][idx], a["N"][idx], a["Ng"][idx], self.rays, n,
                                    rng, self.eps, weight=w, batches=ENV_BATCHES)
        everything = np.arange(len(a["Ps"]))
        est, err = run(everything, int(rays))
        scale = max(float(np.median(est.sum(1))), 1e-300) if len(est) else 1.0
        bad = np.nonzero(np.sqrt((err ** 2).sum(1)) > ENV_TARGET * np.maximum(est.sum(1), scale))[0]
        if len(bad):  # as _env_estimate: 4x the rays more where noisy, combined by ray count
            e2, s2 = run(bad, 4 * int(rays))
            n1, n2 = float(rays), 4.0 * float(rays)
            est[bad] = (n1 * est[bad] + n2 * e2) / (n1 + n2)
            err[bad] = np.sqrt(n1 ** 2 * err[bad] ** 2 + n2 ** 2 * s2 ** 2) / (n1 + n2)
        return est, err

    def irradiance_at_points(self, a: dict[str, Any], mix: float, energy: bool, seed: int = 0
                             ) -> tuple[np.ndarray, np.ndarray]:
        """E A (as ``irradiance``) with the environment estimated at the points themselves
        (env_direct), and the standard error of its environment part (N, 3)."""
        U, vis = self.irradiance_parts(a, mix, energy)
        E = (U * vis[..., None]).sum(0) if len(U) else np.zeros((len(a["P"]), 3))
        se = np.zeros_like(E)
        if self.env is not None and len(E):
            cm = _safe_pow(a["C"], mix)
            est, err = self.env_direct(a, energy, seed=seed)
            E, se = E + est * cm, err * cm
        return E, se

    def env_relative_error(self, tri: np.ndarray) -> np.ndarray:
        """The standard error of the environment's (full) irradiance at triangles ``tri`` relative to it."""
        v, e = self.env_here(tri)
        out: np.ndarray = e / np.maximum(v, 1e-300)
        return out

    def env_here(self, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(mean irradiance r+g+b, its standard error) of the full estimate at the points of ``tri``."""
        ids = 3 * tri[:, None] + np.arange(3)[None]
        return (self.env_val["full"][ids].sum(2).mean(1),
                np.sqrt((self.env_err["full"][ids] ** 2).sum(2).mean(1)))

    def env_specular(self, a: dict[str, Any], V: np.ndarray, rng: np.random.Generator | None = None,
                     rays: int = ENV_SPEC_RAYS) -> np.ndarray:
        """int L(w) KS(N, w, V) V(w) dw by stratified Beckmann importance sampling (seed 000 eq. 15-16):
        h ~ P_H(h) cos / pi, w = reflect(-V, h), pdf(w) = P_H cos / (4 pi V.h). ``rng``: the samples'
        generator (default: the surface's)."""
        rng = self.env_rng if rng is None else rng
        from skinviewer.physics.environment import sample_equirect, tangent_frames
        from skinviewer.physics.specular import beckmann
        sp = self.s.specular
        n_pts = len(V)
        out = np.zeros((n_pts, 3))
        k = math.isqrt(rays)
        batches = []
        for s0 in range(0, n_pts, 4096):
            sl = slice(s0, min(n_pts, s0 + 4096))
            N, Vs, m = a["N"][sl], V[sl], np.maximum(a["m"][sl], 1e-3)
            cnt = len(N)
            i, j = np.meshgrid(np.arange(k), np.arange(k))
            u1 = (i.ravel()[None] + rng.random((cnt, k * k))) / k
            u2 = (j.ravel()[None] + rng.random((cnt, k * k))) / k
            t2 = -(m[:, None] ** 2) * np.log1p(-np.minimum(u1, 1 - 1e-12))
            ch = 1.0 / np.sqrt(1.0 + t2)
            sh = np.sqrt(np.maximum(1.0 - ch * ch, 0.0))
            t, b = tangent_frames(N)
            phi = 2.0 * math.pi * u2
            h = (sh * np.cos(phi))[..., None] * t[:, None] + (sh * np.sin(phi))[..., None] * b[:, None] \
                + ch[..., None] * N[:, None]
            vh = (Vs[:, None] * h).sum(2)
            w = 2.0 * vh[..., None] * h - Vs[:, None]
            nl = (N[:, None] * w).sum(2)
            ok = (nl > 0) & (vh > 0) & ((a["Ng"][sl][:, None] * w).sum(2) > 0)
            pdf = beckmann(ch, m[:, None]) * ch / (4.0 * math.pi * np.maximum(vh, 1e-12))
            ks = ks_specular(np.broadcast_to(N[:, None], w.shape), w, np.broadcast_to(Vs[:, None], w.shape),
                             m[:, None], a["rho"][sl][:, None], sp.f0)
            f = np.where(ok, ks / np.maximum(pdf, 1e-300), 0.0)
            o = np.repeat(a["Ps"][sl] + a["Ng"][sl] * self.eps, k * k, axis=0)
            dd = np.ascontiguousarray(w.reshape(-1, 3))
            okf = ok.reshape(-1) & (f.reshape(-1) > 0)
            vis = np.zeros(len(dd), bool)
            if okf.any():
                vis[okf] = ~self.rays.intersects_any(o[okf], dd[okf])
            assert self.env is not None  # env_specular runs only with an environment light
            L = sample_equirect(self.env_img, dd, self.env.yaw).reshape(cnt, k * k, -1)
            val = L * (f * vis.reshape(cnt, k * k))[..., None]
            out[sl] = val.mean(1)
            # the spread of the samples / sqrt(n): an upper bound of a stratified estimate's error
            batches.append(np.sqrt((val.std(1) ** 2).sum(1)) / (k * k) ** 0.5)
        self.env_spec_err = np.concatenate(batches) if batches else np.zeros(0)
        return out

    def beam_sources(self, mix: float, energy: bool, rays: int = BEAM_RAYS) -> gt.PointSources:
        pos, power = [], []
        k = np.arange(rays) + 0.5
        rad, ang = np.sqrt(k / rays), k * math.pi * (3.0 - math.sqrt(5.0))  # sunflower: equal areas
        for light in self.lights:
            if light.kind != "beam":
                continue
            L = np.asarray(light.direction, np.float64)
            L /= np.linalg.norm(L)
            u = np.cross(L, [1.0, 0, 0] if abs(L[0]) < 0.9 else [0, 1.0, 0])
            u /= np.linalg.norm(u)
            v = np.cross(L, u)
            r = light.beam_radius
            far = np.linalg.norm(np.asarray(light.position) - self.center) + 3 * self.radius
            o = (np.asarray(light.position, np.float64)[None] + L[None] * far
                 + r * (rad * np.cos(ang))[:, None] * u + r * (rad * np.sin(ang))[:, None] * v)
            d = np.broadcast_to(-L, o.shape).copy()
            tri, _, loc = self.rays.intersects_id(o, d, multiple_hits=False, return_locations=True)
            if len(tri) == 0:
                continue
            bary = _barycentric(self.P[self.F[tri]], loc)
            a = self.attributes(tri, bary)
            ndl = np.maximum((a["N"] * L).sum(1), 0.0)
            ngl = np.maximum(np.abs((a["Ng"] * L).sum(1)), 1e-3)
            rho = self.rho_dt(ndl, a["m"], a["rho"]) if energy else 1.0
            Lc = np.asarray(light.color, np.float64) * light.intensity
            area = math.pi * (r * self.mm) ** 2 / rays  # each ray's share of the beam, mm^2
            power.append(Lc[None] * (area * ndl / ngl * rho)[:, None] * _safe_pow(a["C"], mix))
            pos.append(a["P"] * self.mm)
        if not pos:
            return gt.PointSources(np.zeros((0, 3)), np.zeros((0, 3)))
        return gt.PointSources(np.concatenate(pos), np.concatenate(power))

    def specular(self, a: dict[str, Any], V: np.ndarray, rng: np.random.Generator | None = None,
                 env_rays: int = ENV_SPEC_RAYS) -> np.ndarray:
        """deon_final.frag's specular: sum_lights Lc KS(N, L, V) vis (KS carries N.L, eq. 35); ``rng``,
        ``env_rays``: the environment's samples (env_specular)."""
        out = np.zeros((len(V), 3))
        sp = self.s.specular
        for light in self.lights:
            L = np.ascontiguousarray(self.light_dir(light, a["P"]))
            Lc = np.asarray(light.color, np.float64) * light.intensity
            if light.kind == "beam":
                rel = a["P"] - np.asarray(light.position)
                perp = rel - (rel * L).sum(1, keepdims=True) * L
                inside = np.linalg.norm(perp, axis=1) <= light.beam_radius
            else:
                inside = np.ones(len(V), bool)
            ks = (ks_specular_lut(a["N"], L, V, a["m"], a["rho"], sp.f0, self.beckmann) if self.beckmann is not None
                  else ks_specular(a["N"], L, V, a["m"], a["rho"], sp.f0))
            on = inside & (ks > 0)
            if not on.any():
                continue
            sub = {k: v[on] for k, v in a.items()}
            vis = self.visible(light, sub, L[on])
            out[on] += Lc[None] * (ks[on] * vis)[:, None]
        if self.env is not None:
            out += self.env_specular(a, V, rng, env_rays)
        return out


def _safe_pow(c: np.ndarray, e: float) -> np.ndarray:
    """deon_safe_pow: C^e with e <= 0 -> 1 and C <= 0 -> 0."""
    if not e > 0:
        return np.ones_like(c)
    c = np.clip(c, 0.0, 1e30)
    return np.where(c > 0, np.power(np.maximum(c, 1e-300), e), 0.0)


def _barycentric(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    den = np.maximum(d00 * d11 - d01 * d01, 1e-300)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    bary = np.stack([1 - v - w, v, w], 1)
    out: np.ndarray = np.clip(bary, 0, 1) / np.maximum(np.clip(bary, 0, 1).sum(1, keepdims=True), 1e-300)
    return out


# -- the camera ------------------------------------------------------------------------------------

def camera_hits(surf: Surface, s: Settings, grid: tuple[int, int] | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ray through every pixel centre: (mask (H, W), triangle ids, barycentrics, eye) top row first.
    ``grid``: cast a coarser (W, H) grid over the same view instead (coverage estimates)."""
    W, H = s.render.width, s.render.height
    view = framed_view(s.camera, surf, (W, H))
    if grid is not None:
        W, H = grid
    inv = np.linalg.inv(view.view_proj)
    i, j = np.meshgrid(np.arange(W), np.arange(H))
    x = (i.ravel() + 0.5) / W * 2 - 1
    y = 1 - (j.ravel() + 0.5) / H * 2
    pts = []
    for z in (-1.0, 1.0):
        p = np.stack([x, y, np.full_like(x, z), np.ones_like(x)], 1) @ inv.T
        pts.append(p[:, :3] / p[:, 3:4])
    d = pts[1] - pts[0]
    d /= np.linalg.norm(d, axis=1)[:, None]
    o = np.broadcast_to(view.eye, d.shape).copy()
    tri, ray, loc = surf.rays.intersects_id(o, d, multiple_hits=False, return_locations=True)
    if surf.cull_back:  # as the raster with scene.back_faces = cull: go on through back faces
        for _ in range(8):
            back = (surf.Ng[tri] * d[ray]).sum(1) > 0.0
            if not back.any():
                break
            keep = ~back
            r2 = ray[back]
            t2, i2, l2 = surf.rays.intersects_id(loc[back] + d[r2] * surf.eps, d[r2], multiple_hits=False,
                                                 return_locations=True)
            tri, ray, loc = np.r_[tri[keep], t2], np.r_[ray[keep], r2[i2]], np.r_[loc[keep], l2]
        front = (surf.Ng[tri] * d[ray]).sum(1) <= 0.0
        tri, ray, loc = tri[front], ray[front], loc[front]
    mask = np.zeros(W * H, bool)
    mask[ray] = True
    order = np.argsort(ray)
    return mask.reshape(H, W), tri[order], _barycentric(surf.P[surf.F[tri[order]]], loc[order]), view.eye


# -- what the reference depends on -----------------------------------------------------------------

def profile_of(s: Settings) -> tuple[np.ndarray, np.ndarray]:
    g = s.deon.gaussians
    return np.array([x.variance for x in g], np.float64), np.array([x.weights for x in g], np.float64)


PROFILE_MODELS = ("gaussians", "dipole", "multipole", "burley")


def model_profile(model: str, material: str | None = None, normalize: bool = True, n: int = 32
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A radial profile of the profile lab (skinviewer.physics.profiles) as (variances, weights (k, 3),
    fit error per channel): non-negative weights on ``n`` fixed log-spaced variances (1e-6 .. 400 mm^2,
    NNLS of physics.fitting on r R(r), eq. 3.1 error). The diffusion then integrates each Gaussian
    exactly. ``normalize``: weights sum to 1 per channel (R_d lives in the albedo, as the profile
    lab's presets)."""
    from skinviewer.physics import profiles as P
    from skinviewer.physics.fitting import fit_gaussians
    prof: P.Dipole | P.Burley | P.Multipole | P.LayeredMultipole
    if model == "dipole":
        m = P.material(material or "Skin1")
        prof = P.Dipole(m.sigma_s_prime, m.sigma_a, m.eta)
    elif model == "burley":
        m = P.material(material or "Skin1")
        A = P.Dipole(m.sigma_s_prime, m.sigma_a, m.eta).total_reflectance()
        prof = P.Burley(A, P.diffuse_mean_free_path(m.sigma_s_prime, m.sigma_a), "searchlight-dmfp")
    elif model == "multipole":
        if material:
            m = P.material(material)
            prof = P.Multipole(m.sigma_s_prime, m.sigma_a, 2.0, m.eta)  # a 2 mm slab
        else:
            prof = P.three_layer_skin()
    else:
        raise KeyError(f"unknown profile model {model!r} (have: {', '.join(PROFILE_MODELS)})")
    fit = fit_gaussians(prof, shared=True, fixed_variances=np.geomspace(1e-6, 400.0, n))
    v, w = np.asarray(fit.variances, np.float64), np.asarray(fit.weights, np.float64)
    keep = w.sum(1) > 0
    v, w = v[keep], w[keep]
    if normalize:
        w = w / np.maximum(w.sum(0, keepdims=True), 1e-300)
    return v, w, np.asarray(fit.errors, np.float64)


TECHNIQUE_ONLY_LIGHT_FIELDS = ("sh_order", "occlusion", "ao_rays", "transfer_order")


def cache_key(s: Settings, h_mm: float, profile: Any = None, split_edges: bool = True, uncertainty: bool = True,
              version: int | None = None) -> str:
    """The cache's key: a hash of everything the truth depends on, ``version`` (default VERSION) first."""
    from skinviewer.engine.renderer import Renderer
    d = s.model_dump(mode="json")
    # the environment's approximations (SH order, baked visibility) are the techniques', not the truth's
    lights = [{k: v for k, v in light.items() if k not in TECHNIQUE_ONLY_LIGHT_FIELDS} for light in d["lights"]]
    parts = {"v": VERSION if version is None else int(version), "scene": Renderer.scene_key(s), "back_faces": s.scene.back_faces, "camera": d["camera"],
             "size": [s.render.width, s.render.height], "lights": lights, "specular": d["specular"],
             "env_files": _env_stamps(s),
             "mix": s.deon.mix, "energy": s.deon.energy_conservation, "h": h_mm,
             "profile": [np.asarray(p).tolist() for p in (profile or profile_of(s))]}
    if not split_edges:
        parts["split_edges"] = False
    if not uncertainty:
        parts["uncertainty"] = False
    return hashlib.sha1(json.dumps(parts, sort_keys=True).encode()).hexdigest()


def _env_stamps(s: Settings) -> list[list[object]]:
    """Size and modification time of each environment file (a changed file is another reference)."""
    out: list[list[object]] = []
    for light in s.lights:
        if light.kind == "environment":
            try:
                st = Path(light.environment).stat()
                out.append([light.environment, st.st_size, st.st_mtime_ns])
            except OSError:
                out.append([light.environment])
    return out


def _cache_path(key: str) -> Path:
    return cache_dir() / "reference" / f"{key}.npz"


MAX_CACHE_BYTES = 2**31  # a cached reference at the largest size (8192^2) is well under this


def load_cached(s: Settings, h_mm: float = DEFAULT_H_MM, profile: ProfileArrays | None = None, split_edges: bool = True,
                uncertainty: bool = True, notes: list[str] | None = None) -> Reference | None:
    """The cached reference of these inputs, or None. An entry that does not validate (truncated or
    not a zip, a missing or wrongly shaped array, a key or size that is not these settings', not a
    regular file) is deleted, and ``notes`` gets one line saying so: the caller recomputes it."""
    key = cache_key(s, h_mm, profile, split_edges, uncertainty)
    p = _cache_path(key)
    if not os.path.lexists(p):
        _discard_stale(s, h_mm, profile, split_edges, uncertainty, notes)
        return None
    try:
        return _validated(p, key, (s.render.height, s.render.width))
    except Exception as exc:  # noqa: BLE001 - anything a damaged file raises (BadZipFile, zlib.error, ...)
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        try:
            os.unlink(p)
            what = "discarded"
        except OSError:
            what = "ignored (it cannot be deleted)"
        if notes is not None:
            notes.append(f"the cached reference {p.name} did not validate ({why}): {what}, recomputing")
        return None


STALE_VERSIONS = 4  # load_cached looks this many truth versions back for an entry of the same inputs


def _discard_stale(s: Settings, h_mm: float, profile: ProfileArrays | None, split_edges: bool, uncertainty: bool,
                   notes: list[str] | None) -> None:
    """An entry of the same inputs computed by an older truth (VERSION - 1 .. - STALE_VERSIONS) is
    deleted, and ``notes`` gets one line saying so: the caller recomputes it (nothing stale is left)."""
    for old in range(VERSION - 1, max(VERSION - 1 - STALE_VERSIONS, 0), -1):
        q = _cache_path(cache_key(s, h_mm, profile, split_edges, uncertainty, version=old))
        if not os.path.lexists(q):
            continue
        try:
            os.unlink(q)
            what = "discarded"
        except OSError:
            what = "ignored (it cannot be deleted)"
        if notes is not None:
            notes.append(f"the cached reference {q.name} is of truth version {old}, this is version {VERSION} "
                         f"({VERSION_CHANGE}): {what}, recomputing")


def _validated(p: Path, key: str, hw: tuple[int, int]) -> Reference:
    from skinviewer.ground.files import read_regular_file
    data = read_regular_file(p, MAX_CACHE_BYTES, what=f"cache entry {p}")
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        arrays = {k: np.array(z[k]) for k in ("lit", "diffuse", "specular", "mask", "position", "meta")}
        names = set(z.files)
        z_unc = np.array(z["uncertainty"]) if "uncertainty" in names else None
        z_env = np.array(z["uncertainty_env"]) if "uncertainty_env" in names else None
    meta = json.loads(str(arrays["meta"]))
    if not isinstance(meta, dict) or meta.get("key") != key:
        raise ValueError("its key is not the file name's")
    for k in ("lit", "diffuse", "specular", "position"):
        a = arrays[k]
        if a.shape != (*hw, 3) or a.dtype != np.float32 or not np.all(np.isfinite(a)):
            raise ValueError(f"'{k}' is {a.shape} {a.dtype}, expected finite float32 {(*hw, 3)}")
    if arrays["mask"].shape != hw or arrays["mask"].dtype != np.bool_:
        raise ValueError(f"'mask' is {arrays['mask'].shape} {arrays['mask'].dtype}, expected bool {hw}")
    unc = None
    if "uncertainty" in names:
        unc = np.array(z_unc)
        if unc.shape != (*hw, 3) or not np.all(np.isfinite(unc)):
            raise ValueError(f"'uncertainty' is {unc.shape}, expected finite {(*hw, 3)}")
    if z_env is not None and (z_env.shape != (*hw, 3) or not np.all(np.isfinite(z_env))):
        raise ValueError(f"'uncertainty_env' is {z_env.shape}, expected finite {(*hw, 3)}")
    meta["cached"] = True
    return Reference(arrays["lit"], arrays["diffuse"], arrays["specular"], arrays["mask"], meta, arrays["position"], unc,
                     z_env)


def _store(key: str, ref: Reference) -> None:
    buf = io.BytesIO()
    assert ref.position is not None, "a computed reference has its surface positions"
    extra: dict[str, Any] = {} if ref.uncertainty is None else {"uncertainty": ref.uncertainty.astype(np.float32)}
    if ref.uncertainty_env is not None:
        extra["uncertainty_env"] = ref.uncertainty_env.astype(np.float32)
    np.savez_compressed(buf, lit=ref.lit.astype(np.float32), diffuse=ref.diffuse.astype(np.float32),
                        specular=ref.specular.astype(np.float32), mask=ref.mask,
                        position=ref.position.astype(np.float32), meta=json.dumps(ref.meta), **extra)
    atomic_write_bytes(_cache_path(key), buf.getvalue())


# -- the reference -----------------------------------------------------------------------------------

# CPU seconds per receiver pixel and per source element, measured on this 2-core machine (default head
# at 512^2: 38.8 s CPU for 60 833 pixels and 2.15 M elements)
_SEC_PER_PIXEL = 2.5e-4
_SEC_PER_ELEMENT = 1.2e-5


def estimate_seconds(n_pixels: int, n_elements: int, uncertainty: bool = False) -> float:
    """CPU seconds of a reference; with its uncertainty, the coarse pass (a quarter of the pixels
    and of the elements) besides."""
    base = _SEC_PER_PIXEL * n_pixels + _SEC_PER_ELEMENT * n_elements
    return base * (1.35 if uncertainty else 1.0)  # default head 512^2: 77.9 vs 58.4 s CPU (cut included)


def build_diffusion(surf: Surface, receivers_mm: np.ndarray | None, h_mm: float, variances: np.ndarray, weights: np.ndarray,
                    mix: float, energy: bool, max_seconds: float | None = None, n_pixels: int | None = None,
                    report: Callable[[str, float], None] | None = None, check: Callable[[], bool] | None = None,
                    split_edges: bool = True, beam_rays: int = BEAM_RAYS, env_level: str = "full") -> gt.Diffusion:
    """Source elements (edge <= h_mm) of every triangle that can reach a receiver, their E A,
    the beams' point sources, and the Diffusion sum over them (``env_level``: the environment's
    estimate, Surface.env_irradiance; "none": without the environment)."""
    report = report or (lambda stage, f: None)
    check = check or (lambda: False)
    mm = surf.mm
    sig_max = math.sqrt(max(float(np.max(variances)), 0.0))
    reach = gt.TRUNCATE * sig_max + 3 * h_mm
    tri_mm = surf.P[surf.F] * mm
    tc = tri_mm.mean(1)
    tr = np.linalg.norm(tri_mm - tc[:, None], axis=2).max(1)
    keep = np.zeros(len(tc), bool)
    if receivers_mm is None:  # the whole surface (the truth session's sources, kept across views)
        keep[:] = True
    elif len(receivers_mm):
        from scipy.spatial import cKDTree
        d, _ = cKDTree(receivers_mm).query(tc, distance_upper_bound=reach + tr.max())
        keep = d <= reach + tr
    vpar, vbary, elem = gt.subdivide(tri_mm, h_mm, keep)
    n_el, n_v = len(elem), len(vpar)
    n_px = (0 if receivers_mm is None else len(receivers_mm)) if n_pixels is None else n_pixels
    est = estimate_seconds(n_px, n_el)
    if max_seconds is not None and est > max_seconds:
        raise ReferenceTooSlow(f"the reference would take about {est:.0f} s of CPU ({n_px} pixels, "
                               f"{n_el} source elements of {h_mm:g} mm), over the {max_seconds:.0f} s limit")
    report("irradiance", 0.0)
    # E A at the element corners (shared inside each parent triangle), per light unshadowed and its
    # visibility; an element's value is the mean of its corners (exact for linear variation)
    n_l = len(surf.shadow_lights())
    U = np.zeros((n_l, n_v, 3))
    vis = np.ones((n_l, n_v), bool)
    env_v = np.zeros((n_v, 3)) if surf.env is not None and env_level != "none" else None
    step = 200_000
    for s0 in range(0, n_v, step):
        if check():
            raise InterruptedError("cancelled")
        sl = slice(s0, min(n_v, s0 + step))
        a_sl = surf.attributes(vpar[sl], vbary[sl])
        U[:, sl], vis[:, sl] = surf.irradiance_parts(a_sl, mix, energy)
        if env_v is not None:  # the environment's occluded irradiance (issue 32): smooth, never cut
            env_v[sl] = surf.env_irradiance(a_sl["tri"], a_sl["bary"], energy, env_level) * _safe_pow(a_sl["C"], mix)
        report("irradiance", sl.stop / max(n_v, 1))
    if env_v is not None:  # one more "light", visible everywhere: the edge cut leaves it as the corners' mean
        U = np.concatenate([U, env_v[None]])
        vis = np.concatenate([vis, np.ones((1, n_v), bool)])
    vpos = np.einsum("vk,vkd->vd", vbary, tri_mm[vpar])
    ea_v = (U * vis[..., None]).sum(0) if len(U) else np.zeros((n_v, 3))
    corners, ea, split = vpos[elem], ea_v[elem].mean(1), None
    if split_edges and n_l:
        corners, ea, split = split_shadow_edges(surf, vpar, vbary, vpos, elem, U, vis, check)
    el = gt.Elements(corners, ea, split=split)
    return gt.Diffusion(el, variances, weights, h_mm, surf.beam_sources(mix, energy, beam_rays))


EDGE_BISECTIONS = 10  # shadow-edge crossings located to 2^-11 of an element edge (0.25 um at 0.5 mm)


def split_shadow_edges(surf: Surface, vpar: np.ndarray, vbary: np.ndarray, vpos: np.ndarray, elem: np.ndarray,
                       U: np.ndarray, vis: np.ndarray, check: Callable[[], bool] | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Elements whose corners disagree on a light's visibility (a cast-shadow edge crosses them) are
    cut along the edge, found by bisecting the two element edges it crosses with shadow rays
    (EDGE_BISECTIONS each) and taken straight inside the element; each piece carries its own side's
    light (that light's unshadowed E A interpolated linearly, times 1 or 0), the others' as before.
    The exact Owen's-T integral then integrates the lit part exactly, so the narrow Gaussians see a
    step where the shadow ray sees one, not the corners' mean smeared over the element.
    Returns (corners (E', 3, 3), E A (E', 3), split (E',) bool: the pieces)."""
    n_l = U.shape[0]
    ev = vis[:, elem]                                   # (L, E, 3)
    carries = (U.sum(2) > 0)[:, elem].any(2)            # (L, E): the light reaches some corner
    mixed = ev.any(2) & ~ev.all(2) & carries
    ea_v = (U * vis[..., None]).sum(0)
    ea = ea_v[elem].mean(1)
    corners = vpos[elem]
    idx = np.nonzero(mixed.any(0))[0]
    if len(idx) == 0:
        return corners, ea, np.zeros(len(elem), bool)
    li = np.argmax(mixed[:, idx], axis=0)               # the first light whose edge crosses it
    v3 = ev[li, idx]                                    # (M, 3)
    lone = np.argmax((v3 != v3[:, [1, 2, 0]]) & (v3 != v3[:, [2, 0, 1]]), axis=1)
    order = (lone[:, None] + np.arange(3)[None]) % 3    # a (the lone corner), b, c, winding kept
    ids = np.take_along_axis(elem[idx], order, 1)       # vertex ids of a, b, c
    parent = vpar[ids[:, 0]]
    va = vis[li, ids[:, 0]]

    def crossing(j: int) -> np.ndarray:
        lo, hi = np.zeros(len(idx)), np.ones(len(idx))
        for _ in range(EDGE_BISECTIONS):
            if check is not None and check():
                raise InterruptedError("cancelled")
            mid = 0.5 * (lo + hi)
            bary = (1.0 - mid)[:, None] * vbary[ids[:, 0]] + mid[:, None] * vbary[ids[:, j]]
            same = np.empty(len(idx), bool)
            for k in range(n_l):
                sel = li == k
                if sel.any():
                    same[sel] = surf.visibility_at(k, parent[sel], bary[sel]) == va[sel]
            lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
        return 0.5 * (lo + hi)

    W, side_a = gt.cut_weights(crossing(1), crossing(2))   # (M, 3 pieces, 3 corners, 3)
    Wm = W.mean(2)                                          # mean weights over a piece's corners
    Uabc = U[:, ids]                                        # (L, M, 3 corners, 3 ch)
    Vabc = vis[:, ids].astype(np.float64)
    # other lights: the corners' mean of U vis (as an unsplit element); the cut light: U x its side
    mean_uv = np.einsum("mpk,lmkc->lmpc", Wm, Uabc * Vabc[..., None])
    mean_u = np.einsum("mpk,lmkc->lmpc", Wm, Uabc)
    rows = np.arange(len(idx))
    side = np.where(va[:, None], side_a[None], 1.0 - side_a[None])  # (M, 3 pieces): lit or not
    piece_ea = mean_uv.sum(0) - mean_uv[li, rows] + mean_u[li, rows] * side[..., None]
    piece_corners = np.einsum("mpqk,mkd->mpqd", W, vpos[ids])
    # the pieces take their element's place (the order of the elements stays the mesh's)
    count = np.ones(len(elem), np.int64)
    count[idx] = 3
    at = np.cumsum(count) - count
    out_c = np.repeat(corners, count, axis=0)
    out_e = np.repeat(ea, count, axis=0)
    split = np.zeros(len(out_c), bool)
    put = (at[idx][:, None] + np.arange(3)[None]).ravel()
    out_c[put] = piece_corners.reshape(-1, 3, 3)
    out_e[put] = piece_ea.reshape(-1, 3)
    split[put] = True
    return out_c, out_e, split


UNCERTAINTY_COARSER = 2.0   # the coarser level of the uncertainty: elements twice as large, half the beam rays
UNCERTAINTY_STRIDE = 2      # its receivers: every 2nd pixel in x and y (then the 3 x 3 maximum)
GCI_SAFETY = 3.0            # Roache's grid convergence index: safety factor 3 for a two-level estimate
TRUNCATE_LOSS = 5e-5        # relative: the weight beyond TRUNCATE sigma, exp(-4.5^2 / 2) = 4e-5, and float32
UNCERTAINTY_NOTE = ("per pixel: 3 |M(h={h:g} mm) - M(h={h2:g} mm, half the beam rays)| (Roache's grid convergence "
                    "index, first order, safety factor 3; the coarse level on every 2nd pixel, the largest of the "
                    "pixel's 3x3 neighbourhood) + |grad M| x the shadow edge's position tolerance (ray offset and "
                    "bisection bracket) + 5e-5 M (truncation), times C^(1-mix) rho_dt(N.V); the lights' specular is exact")


def coarse_uncertainty(surf: Surface, mask: np.ndarray, x_mm: np.ndarray, ea_here: np.ndarray, M: np.ndarray,
                       h_mm: float, variances: np.ndarray, weights: np.ndarray, mix: float, energy: bool,
                       split_edges: bool = True, check: Callable[[], bool] | None = None) -> np.ndarray:
    """The truth's own uncertainty at each receiver (N, 3), Roache's grid convergence index (1994):
    GCI_SAFETY |M_h - M_2h| / (2^p - 1) with p = 1 (the default head's residual halves per halving of
    h), the coarse level with elements UNCERTAINTY_COARSER times as large and half the beam rays, run
    on every UNCERTAINTY_STRIDE-th pixel (and every pixel no such pixel neighbours); each pixel takes
    the largest of its 3 x 3 neighbourhood (a feature between samples is covered). Plus what both
    levels share: a shadow edge's position is known to the shadow ray's offset (2 eps, at most 1 mm x
    2e-5 of the scene) and half the bisection's last bracket, so |grad M| (across pixels, 3 x 3 max)
    times that; and the truncation of every Gaussian at TRUNCATE sigma (TRUNCATE_LOSS M)."""
    from scipy.ndimage import binary_dilation, maximum_filter
    H, W = mask.shape
    k = UNCERTAINTY_STRIDE
    grid = np.zeros((H, W), bool)
    grid[::k, ::k] = True
    grid &= mask
    sel_img = grid | (mask & ~binary_dilation(grid, np.ones((3, 3), bool)))
    sel = sel_img[mask]
    h2 = UNCERTAINTY_COARSER * h_mm
    diff2 = build_diffusion(surf, x_mm[sel], h2, variances, weights, mix, energy, check=check,
                            split_edges=split_edges, beam_rays=BEAM_RAYS // 2)
    M2 = diff2.exitance(x_mm[sel], ea_here[sel], cancelled=check)
    rows, cols = np.nonzero(mask)

    def max3(vals: np.ndarray, where: np.ndarray) -> np.ndarray:
        img = np.full((H, W, 3), -np.inf)
        img[rows[where], cols[where]] = vals
        img = maximum_filter(img, size=(3, 3, 1), mode="constant", cval=-np.inf)
        out: np.ndarray = np.maximum(img[mask], 0.0)
        return out

    u = max3(GCI_SAFETY * np.abs(M[sel] - M2), sel)
    out: np.ndarray = u + edge_position_uncertainty(surf, mask, x_mm, M, h_mm) + TRUNCATE_LOSS * np.abs(M)
    return out


def edge_position_uncertainty(surf: Surface, mask: np.ndarray, x_mm: np.ndarray, M: np.ndarray, h_mm: float
                              ) -> np.ndarray:
    """What every level of the truth shares (coarse_uncertainty): a shadow edge's position is known to
    the shadow ray's offset and half the bisection's last bracket, so |grad M| (between 4-neighbours,
    per mm of surface, the largest of the pixel's 3 x 3 neighbourhood) times that (N, 3)."""
    from scipy.ndimage import maximum_filter
    H, W = mask.shape
    rows, cols = np.nonzero(mask)
    full = np.zeros((H, W, 3))
    pos = np.full((H, W, 3), np.nan)
    full[mask], pos[mask] = M, x_mm
    grad = np.zeros((H, W, 3))
    for ax in (0, 1):
        dm = np.abs(np.diff(full, axis=ax))
        dx = np.linalg.norm(np.diff(pos, axis=ax), axis=2, keepdims=True)
        both = np.isfinite(dx) & (dx > 0)
        g = np.where(both, dm / np.where(both, dx, 1.0), 0.0)
        sl = [slice(None)] * 3
        sl[ax] = slice(1, None)
        grad[tuple(sl)] = np.maximum(grad[tuple(sl)], g)
        sl[ax] = slice(None, -1)
        grad[tuple(sl)] = np.maximum(grad[tuple(sl)], g)
    delta = 2.0 * surf.eps * surf.mm + 0.5 * h_mm * 2.0 ** -EDGE_BISECTIONS
    img = np.full((H, W, 3), -np.inf)
    img[rows, cols] = grad[mask]
    img = maximum_filter(img, size=(3, 3, 1), mode="constant", cval=-np.inf)
    out: np.ndarray = np.maximum(img[mask], 0.0) * delta
    return out


ENV_MC_K = 3.0              # the environment's Monte Carlo error: K standard errors (as ENV_POINT_K)
ENV_MC_LOCAL = 0.5          # a Gaussian with sigma < 0.5 x the median triangle edge reads the pixel's own triangle's estimates
ENV_MC_NOTE = ("; with an environment: its Monte Carlo error, {k:g} standard errors of M propagated from the "
               "independent estimates' (each at least its triangle's mean) through the diffusion "
               "sum (the Gaussians narrower than half a triangle read the pixel's triangle's three estimates "
               "through the interpolation weights, the wider ones each estimate's share of its triangle as a "
               "Gaussian blob), + {k:g} standard errors of the environment's specular")


def env_mc_uncertainty(surf: Surface, a: dict[str, Any], variances: np.ndarray, weights: np.ndarray, mix: float,
                       k: float = ENV_MC_K, floor: bool = True, chunk: int = 1024) -> np.ndarray:
    """The environment's Monte Carlo error in M at receivers ``a`` (Surface.attributes) (N, 3): K standard
    deviations of sum_p eps_p c_p(x), eps_p the independent errors of the full level's estimates (their
    standard errors from ENV_BATCHES batches; with ``floor`` each at least the mean variance of its
    triangle's three estimates: a 3-degree-of-freedom estimate is 3x too small at ~5 % of the points,
    a pooled 12-degree one almost never) and c_p(x) = sum_i w_i x (Gaussian i's sum over the elements of estimate p's
    interpolation weight phi_p x C^mix): the diffusion sum is linear in the elements' E A. A Gaussian
    narrower than ENV_MC_LOCAL x the median triangle edge stays inside x's triangle, where phi_p is
    linear, so its mean there is phi_p(x): c_p = w_i phi_p(x) C^mix(x) for the three estimates of x's
    own triangle (unit mass). A wider one: estimate p as a blob of its share of the triangle's area
    a_p = A / 3 with the spread s_p^2 = a_p / (2 pi) (a disc's), c_p = w_i a_p C^mix(y_p) G(v_i + s_p^2,
    |x - y_p|), over the estimates within 3 sqrt(v_i + s_p^2) (the variance beyond: exp(-9) of it).
    Without an environment: zeros."""
    mm = surf.mm
    x_mm, tri, bary = a["P"] * mm, a["tri"], a["bary"]
    out = np.zeros((len(x_mm), 3))
    if surf.env is None or len(x_mm) == 0:
        return out
    from scipy.spatial import cKDTree
    done = np.nonzero(surf.env_done["full"])[0]
    if len(done) == 0:
        return out
    se = surf.env_err["full"][done]
    sig2 = se ** 2
    if floor:  # pooled over the triangle's three estimates (12 degrees of freedom), never below its own
        tri_of = done // 3
        tot = np.zeros((len(surf.F), 3))
        cnt = np.bincount(tri_of, minlength=len(surf.F)).astype(np.float64)
        for ch in range(3):
            tot[:, ch] = np.bincount(tri_of, sig2[:, ch], minlength=len(surf.F))
        sig2 = np.maximum(sig2, tot[tri_of] / np.maximum(cnt[tri_of], 1.0)[:, None])
    tri_mm = surf.P[surf.F] * mm
    area = 0.5 * np.linalg.norm(np.cross(tri_mm[:, 1] - tri_mm[:, 0], tri_mm[:, 2] - tri_mm[:, 0]), axis=1)
    edge = float(np.median(np.sqrt(2.0 * area[np.unique(done // 3)])))
    v = np.asarray(variances, np.float64).ravel()
    w = np.asarray(weights, np.float64).reshape(len(v), 3)
    on = np.any(w > 0, axis=1)
    local = on & (np.sqrt(np.maximum(v, 0.0)) < ENV_MC_LOCAL * edge)
    wide = np.nonzero(on & ~local)[0]
    pos = np.full(len(surf.env_done["full"]), -1, np.int64)
    pos[done] = np.arange(len(done))
    # the narrow Gaussians: x's own triangle's estimates through the interpolation weights
    ids, phi = surf._env_support("full", tri, bary)               # (N, 3), (N, 3)
    own = pos[ids]
    c_own = phi[..., None] * (w[local].sum(0)[None] * _safe_pow(a["C"], mix))[:, None]  # (N, 3 estimates, 3 ch)
    c_own = np.where((own >= 0)[..., None], c_own, 0.0)
    own = np.maximum(own, 0)
    if len(wide):
        a_pt = surf.attributes(done // 3, _ENV_B[done % 3])
        y = a_pt["P"] * mm
        a_p = area[done // 3] / 3.0
        q = a_p[:, None] * _safe_pow(a_pt["C"], mix)  # a_p C^mix (P, 3)
        s2 = a_p / (2.0 * math.pi)
        tree = cKDTree(y)

        def blob(d2: np.ndarray, j: np.ndarray) -> np.ndarray:
            """sum over the wide Gaussians of w_i a_p C^mix G(v_i + s_p^2, d) (pairs, 3)."""
            ve = v[wide][None] + s2[j][:, None]
            g = np.exp(-d2[:, None] / (2.0 * ve)) / (2.0 * math.pi * ve)
            res: np.ndarray = (g @ w[wide]) * q[j]
            return res
        reach = 3.0 * math.sqrt(float(v[wide].max()) + float(s2.max()))
        for s0 in range(0, len(x_mm), chunk):
            sl = slice(s0, min(len(x_mm), s0 + chunk))
            sm = cKDTree(x_mm[sl]).sparse_distance_matrix(tree, reach, output_type="ndarray")
            i, j, d = sm["i"].astype(np.int64), sm["j"].astype(np.int64), sm["v"]
            var = blob(d * d, j) ** 2 * sig2[j]
            for ch in range(3):
                out[sl, ch] = np.bincount(i, var[:, ch], minlength=sl.stop - s0)
        # x's own estimates: the wide part's coefficient there, to combine with the narrow one's
        d2 = ((x_mm[:, None] - y[own]) ** 2).sum(2)
        c_wide = blob(d2.ravel(), own.ravel()).reshape(c_own.shape)
        out += (((c_own + c_wide) ** 2 - c_wide ** 2) * sig2[own]).sum(1)
    else:
        out += (c_own ** 2 * sig2[own]).sum(1)
    res: np.ndarray = k * np.sqrt(np.maximum(out, 0.0))
    return res


def compute_reference(s: Settings, h_mm: float = DEFAULT_H_MM, profile: ProfileArrays | None = None,
                      use_cache: bool = True,
                      max_seconds: float | None = None, scene: tuple[MeshData, float] | None = None,
                      progress: Callable[[str, float], None] | None = None,
                      cancelled: Callable[[], bool] | None = None, split_edges: bool = True,
                      uncertainty: bool = True) -> Reference:
    """The ground truth of ``s`` (see the module doc). ``profile``: (variances, weights (k, 3)) to
    use instead of ``s.deon.gaussians``. ``max_seconds``: raise ReferenceTooSlow (before the
    expensive part) when the estimate exceeds it. ``progress(stage, fraction)``; ``cancelled()``
    -> True stops with InterruptedError. ``scene``: (mesh, mm per unit) instead of s.scene (not
    cached). ``uncertainty``: also the per-pixel uncertainty of ``lit`` (coarse_uncertainty, about
    +25 % CPU time; with an environment light + env_mc_uncertainty, < 1 % more, kept apart in
    ``uncertainty_env`` too). ``split_edges``: False = elements crossed by a shadow edge carry their corners'
    mean (the version-4 truth; for comparisons)."""
    key = cache_key(s, h_mm, profile, split_edges, uncertainty)
    if scene is not None:
        use_cache = False
    cache_notes: list[str] = []
    if use_cache:
        hit = load_cached(s, h_mm, profile, split_edges, uncertainty, notes=cache_notes)
        if hit is not None:
            return hit
    report = progress or (lambda stage, f: None)
    check = cancelled or (lambda: False)
    t0 = time.perf_counter()
    times: dict[str, float] = {}
    variances, weights = profile if profile is not None else profile_of(s)
    mix, energy = s.deon.mix, s.deon.energy_conservation
    report("scene", 0.0)
    mesh, mm = scene if scene is not None else load_scene(s)
    surf = Surface(mesh, mm, s)
    if max_seconds is not None:  # before any per-pixel work: coverage from a 64 x 64 ray grid
        cover = camera_hits(surf, s, grid=(64, 64))[0].mean()
        tri_mm = surf.P[surf.F] * mm
        area = 0.5 * np.linalg.norm(np.cross(tri_mm[:, 1] - tri_mm[:, 0], tri_mm[:, 2] - tri_mm[:, 0]), axis=1).sum()
        n_px = int(cover * s.render.width * s.render.height)
        n_el = int(0.5 * area / (0.17 * h_mm * h_mm))  # about half the surface can reach a visible point
        est = estimate_seconds(n_px, n_el, uncertainty)
        if est > max_seconds:
            raise ReferenceTooSlow(f"the reference would take about {est:.0f} s of CPU (~{n_px} pixels, "
                                   f"~{n_el} source elements of {h_mm:g} mm), over the {max_seconds:.0f} s limit")
    mask, tri, bary, eye = camera_hits(surf, s)
    a = surf.attributes(tri, bary)
    times["camera"] = time.perf_counter() - t0
    report("scene", 1.0)
    x_mm = a["P"] * mm
    diff = build_diffusion(surf, x_mm, h_mm, variances, weights, mix, energy, max_seconds, report=report, check=check,
                           split_edges=split_edges)
    n_el = len(diff.el.area)
    est = estimate_seconds(len(x_mm), n_el, uncertainty)
    points = diff.points
    ea_here = surf.irradiance(a, mix, energy)
    times["irradiance"] = time.perf_counter() - t0 - times["camera"]
    M = diff.exitance(x_mm, ea_here, progress=lambda f: report("diffusion", f), cancelled=check)
    times["diffusion"] = time.perf_counter() - t0 - times["camera"] - times["irradiance"]
    H, W = mask.shape
    u_M = u_env_M = None
    if uncertainty:
        t1 = time.perf_counter()
        report("uncertainty", 0.0)
        u_M = coarse_uncertainty(surf, mask, x_mm, ea_here, M, h_mm, variances, weights, mix, energy,
                                 split_edges, check)
        report("uncertainty", 1.0)
        times["uncertainty"] = time.perf_counter() - t1
        if surf.env is not None:  # the environment's Monte Carlo error (issue 30: in the creases it dominates)
            t1 = time.perf_counter()
            u_env_M = env_mc_uncertainty(surf, a, variances, weights, mix)
            times["uncertainty_env"] = time.perf_counter() - t1
            t1 = time.perf_counter()
            u_env_M = u_env_M + env_interpolation_uncertainty(surf, a, variances, weights, mix, energy, h_mm)
            times["uncertainty_env_interpolation"] = time.perf_counter() - t1
    # view-dependent: eq. (34) rho_dt(N.V) and C^(1 - mix), and the specular (eq. 35)
    V = eye[None] - a["P"]
    V /= np.maximum(np.linalg.norm(V, axis=1), 1e-300)[:, None]
    N = a["N"] * np.where((a["Ng"] * V).sum(1) < 0, -1.0, 1.0)[:, None]  # a back face: as deon_final
    a = {**a, "N": N}
    rho_v = surf.rho_dt((N * V).sum(1), a["m"], a["rho"]) if energy else np.ones(len(V))
    diffuse = M * _safe_pow(a["C"], 1.0 - mix) * rho_v[:, None]
    spec = surf.specular(a, V)
    env_meta = {}
    if surf.env is not None:  # the Monte Carlo's standard errors (issue 32)
        rel = surf.env_relative_error(tri)
        e_here, e_err = surf.env_here(tri)
        lit_sum = np.maximum((diffuse + spec).sum(1), 1e-300)
        spec_rel = surf.env_spec_err / lit_sum
        env_meta = {"diffuse_rays": ENV_DIFFUSE_RAYS, "specular_rays": ENV_SPEC_RAYS,
                    "diffuse_rays_mean": surf.env_rays_used / max(surf.env_points_done, 1),
                    "irradiance_rms_stderr_over_mean": float(np.sqrt((e_err ** 2).mean()) / max(e_here.mean(), 1e-300)),
                    "irradiance_rel_stderr_p50": float(np.median(rel)), "irradiance_rel_stderr_p95": float(np.percentile(rel, 95)),
                    "specular_stderr_of_pixel_p50": float(np.median(spec_rel)),
                    "specular_stderr_of_pixel_p95": float(np.percentile(spec_rel, 95))}
    H, W = mask.shape
    imgs = []
    scale = _safe_pow(a["C"], 1.0 - mix) * rho_v[:, None]
    u_lit = u_env_lit = None
    if u_M is not None:
        u_lit = u_M * scale
        if u_env_M is not None:
            u_env_lit = u_env_M * scale
            if surf.env_spec_err is not None:  # K standard errors of its specular, every channel
                u_env_lit = u_env_lit + ENV_MC_K * surf.env_spec_err[:, None]
            u_lit = u_lit + u_env_lit
    for arr in (diffuse + spec, diffuse, spec, a["P"]) + tuple(x for x in (u_lit, u_env_lit) if x is not None):
        img = np.zeros((H * W, 3))
        img[mask.ravel()] = np.nan_to_num(arr, nan=0.0, posinf=0.0, neginf=0.0)
        imgs.append(img.reshape(H, W, 3))
    times["total"] = time.perf_counter() - t0
    meta = {"key": key, "version": VERSION, "h_mm": h_mm, "elements": n_el, "pixels": int(mask.sum()),
            "beam_rays": 0 if points is None else len(points.position), "seconds": times, "estimate_s": est,
            "plan": diff.plan(), "mm_per_unit": mm, "cached": False, "env": env_meta}
    if u_M is not None:
        meta["uncertainty"] = UNCERTAINTY_NOTE.format(h=h_mm, h2=UNCERTAINTY_COARSER * h_mm) + \
            (ENV_MC_NOTE.format(k=ENV_MC_K) + ENV_INTERP_NOTE
             if surf.env is not None else "")
    ref = Reference(imgs[0], imgs[1], imgs[2], mask, meta, imgs[3], imgs[4] if u_M is not None else None,
                    imgs[5] if u_env_lit is not None else None)
    if use_cache:
        _store(key, ref)
    if cache_notes:
        ref.meta["notes"] = cache_notes
    report("done", 1.0)
    return ref


# -- the truth converged further where a comparison needs it (issue 30 item 4) -----------------------
#
# The p99 of a technique against the truth lives in a few hundred pixels (on the heads at 192^2: dark
# pixels inside cast shadows and crevices), and the truth's stated uncertainty there -- the first-order
# GCI of 0.5 mm elements, taken on every 2nd pixel and spread over 3 x 3 -- is 10-100x the difference two
# configurations make. refine_at recomputes those pixels only: every Gaussian with elements of h / 2,
# the narrow ones (sigma < h, whose discretisation dominates: the narrowest converges at first order)
# further, down to their own sigma (h / 8 for the narrowest), each only over the elements its reach needs.

REFINE_HALVINGS = 3        # the narrowest Gaussians' elements down to h / 8 at the refined pixels
REFINE_ENV_FACTOR = 8      # the environment's estimates near them with 8 x the rays more (its error / 3)
REFINE_ENV_OWN_SIGMA = 0.25  # mm: Gaussians narrower than this read the environment at the pixel's own point
REFINE_BATCH = 128         # pixels refined together (the finest level: ~2-3 M elements a batch on the head)
REFINE_NOTE = ("at the {n} refined pixels: every Gaussian with elements of {h1:g} mm, the narrow ones down to their "
               "own sigma (at most {hn:g} mm), the value the finest level's; per Gaussian 3 |M(finest) - M(the level "
               "above)| (the GCI as elsewhere, at the pixel itself) + the edge-position and truncation terms; with an "
               "environment, the Gaussians narrower than {own:g} mm read its irradiance estimated at the pixel's own "
               "point ({rays} rays; + 3 standard errors + the interpolation's error scaled to sigma quadratically), the "
               "wider ones the interpolated estimates, those within {h:g} mm with {f}x the rays more (+ 3 standard "
               "errors + |interpolated - the pixel's own estimate|), x C^mix x the Gaussians' weight")


def refine_at(s: Settings, ref: Reference, select: np.ndarray, h_mm: float = DEFAULT_H_MM,
              halvings: int = REFINE_HALVINGS, profile: ProfileArrays | None = None,
              report: Callable[[str, float], None] | None = None,
              cancelled: Callable[[], bool] | None = None, surface: Surface | None = None,
              env_factor: int = REFINE_ENV_FACTOR) -> Reference:
    """``ref`` (compute_reference(s, h_mm, profile)) converged further at the pixels ``select`` (H, W):
    Gaussian i is summed at h 2^-j for j = 0 .. J_i, J_i the halvings that bring the elements to its own
    sigma (at least 1, at most ``halvings``), over the elements that reach the selected pixels for that Gaussian (build_diffusion);
    the pixel's value is the sum of each Gaussian's finest level, its uncertainty the sum over Gaussians
    of GCI_SAFETY |M_i(J_i) - M_i(J_i - 1)| (computed at the pixel: no 3 x 3 spreading) plus the
    edge-position (edge_position_uncertainty, of the whole image) and truncation terms, times
    C^(1-mix) rho_dt(N.V) as compute_reference. Other pixels are ``ref``'s. meta["refined"] says how
    many pixels, the levels and the seconds. ValueError if ``ref`` is not this view's truth.
    ``surface``: a Surface of these settings to reuse (its environment's estimates are kept: a second
    call on more pixels pays only for the new ones). ``env_factor``: the environment's rays at the
    pixels and near them, x ENV_DIFFUSE_RAYS (its Monte Carlo error falls as 1 / sqrt of it)."""
    report = report or (lambda stage, f: None)
    if ref.uncertainty is None or ref.position is None:
        raise ValueError("refine_at needs a truth with its uncertainty and positions")
    sel_img = np.asarray(select, bool) & ref.mask
    if sel_img.shape != ref.mask.shape:
        raise ValueError(f"the selection is {sel_img.shape}, the truth {ref.mask.shape}")
    if not sel_img.any():
        return ref
    t0 = time.perf_counter()
    variances, weights = profile if profile is not None else profile_of(s)
    variances, weights = np.asarray(variances, np.float64), np.asarray(weights, np.float64)
    mix, energy = s.deon.mix, s.deon.energy_conservation
    if surface is None:
        mesh, mm = load_scene(s)
        surf = Surface(mesh, mm, s)
    else:
        surf, mm = surface, surface.mm
    mask, tri, bary, eye = camera_hits(surf, s)
    if mask.shape != ref.mask.shape or not np.array_equal(mask, ref.mask):
        raise ValueError("the truth given is not of these settings' view")
    a = surf.attributes(tri, bary)
    x_mm = a["P"] * mm
    V = eye[None] - a["P"]
    V /= np.maximum(np.linalg.norm(V, axis=1), 1e-300)[:, None]
    N = a["N"] * np.where((a["Ng"] * V).sum(1) < 0, -1.0, 1.0)[:, None]  # as compute_reference
    rho_v = surf.rho_dt((N * V).sum(1), a["m"], a["rho"]) if energy else np.ones(len(V))
    post = _safe_pow(a["C"], 1.0 - mix) * rho_v[:, None]
    sel = sel_img[mask]
    xs = x_mm[sel]
    a_sel = {k: v[sel] for k, v in a.items()}
    n_sel = int(sel.sum())
    # J_i: elements down to the Gaussian's own width (h 2^-J <= sigma), at least one halving
    sig = np.sqrt(np.maximum(variances, 1e-300))
    depth = np.clip(np.ceil(np.log2(h_mm / sig)), 1, max(int(halvings), 1)).astype(int)
    has_env = surf.env is not None
    # with an environment, the Gaussians narrower than REFINE_ENV_OWN_SIGMA take its irradiance at the
    # pixel's own point (estimated there with many rays) instead of the estimates interpolated over the
    # mesh's ~2.7 mm triangles, which in a crease are off by tens of % (the session truth's choice, issue 34)
    own_env = has_env & (sig < REFINE_ENV_OWN_SIGMA)
    u_env = np.zeros((n_sel, 3))
    if has_env:
        report("environment", 0.0)
        from scipy.spatial import cKDTree
        # the wider Gaussians read the interpolated estimates: those of the triangles within h of a
        # refined pixel with more rays
        tri_mm = surf.P[surf.F] * mm
        tc = tri_mm.mean(1)
        tr = np.linalg.norm(tri_mm - tc[:, None], axis=2).max(1)
        dist, _ = cKDTree(xs).query(tc, distance_upper_bound=h_mm + tr.max())
        surf.env_more_rays(np.nonzero(dist <= h_mm + tr)[0], energy, env_factor)
        cm = _safe_pow(a_sel["C"], mix)
        interp = surf.env_irradiance(a_sel["tri"], a_sel["bary"], energy) * cm
        own, se_own = surf.env_direct(a_sel, energy, rays=ENV_DIFFUSE_RAYS * int(env_factor),
                                      seed=n_sel if env_factor == REFINE_ENV_FACTOR else 1000 * n_sel + int(env_factor))
        own, se_own = own * cm, se_own * cm
        check = np.abs(interp - own)  # the interpolation at the pixel (both estimates' noise in it)
        se_int = surf.env_stderr(a_sel["tri"], a_sel["bary"]) * cm
        # the wider Gaussians: K standard errors of the interpolated estimate + the check, at full weight
        u_env = (ENV_POINT_K * se_int + check) * weights[~own_env].sum(0)[None]
        report("environment", 1.0)
    ea_full = surf.irradiance(a_sel, mix, energy)
    ea_key = surf.irradiance(a_sel, mix, energy, env_level="none") if has_env else ea_full
    n_lv = depth + 1
    per = {i: np.zeros((int(n_lv[i]), n_sel, 3)) for i in range(len(variances)) if np.any(weights[i] > 0)}
    env_add = {i: np.zeros((n_sel, 3)) for i in per}  # the own-environment Gaussians' environment part
    if has_env:
        t = tri_mm[a_sel["tri"]]
        L = np.sqrt(np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1))  # ~ the triangle's size
    # the pixels in batches of REFINE_BATCH, nearest together: the finest levels' elements (whole mesh
    # triangles subdivided to 0.0625 mm) grow with the area the batch spans
    order = np.lexsort((xs[:, 2], xs[:, 1], xs[:, 0]))
    batches = np.array_split(order, max(1, math.ceil(n_sel / REFINE_BATCH)))
    for b_i, pix in enumerate(batches):
        for j in range(int(depth.max()) + 1):
            report("refine", (b_i + j / (depth.max() + 1)) / len(batches))
            for group, env_level, ea in ((~own_env, "full", ea_full), (own_env, "none", ea_key)):
                idx = [i for i in per if group[i] and depth[i] >= j]
                if not idx:
                    continue
                diff = build_diffusion(surf, xs[pix], h_mm * 2.0 ** -j, variances[idx], weights[idx], mix, energy,
                                       check=cancelled, env_level=env_level)
                for n_i, i in enumerate(idx):
                    per[i][j, pix] = diff.exitance(xs[pix], ea[pix], only=[n_i], cancelled=cancelled)
                if j == 0 and env_level == "none":  # each own-environment Gaussian's mass over the surface at x
                    ones = gt.Diffusion(gt.Elements(diff.el.corners, np.ones_like(diff.el.ea), split=diff.el.split),
                                        variances[idx], weights[idx], h_mm)
                    for n_i, i in enumerate(idx):
                        mass_w = ones.exitance(xs[pix], np.ones((len(pix), 3)), only=[n_i], cancelled=cancelled)
                        env_add[i][pix] = mass_w * own[pix]  # mass_w: w_i x the Gaussian's mass at x
                        # K standard errors of the estimate at x, and the environment's change over the
                        # Gaussian: the interpolation's error at x scaled from the triangle to sigma, quadratically
                        u_env[pix] += mass_w * (ENV_POINT_K * se_own[pix]
                                                + (sig[i] / np.maximum(L[pix], sig[i]))[:, None] ** 2 * check[pix])
                del diff
    levels = {i: lv + env_add[i] for i, lv in per.items()}
    M_new = sum(lv[-1] for lv in levels.values())
    u_gci = sum(GCI_SAFETY * np.abs(lv[-1] - lv[-2]) for lv in levels.values() if len(lv) > 1)
    M_all = ref.diffuse[mask] / np.maximum(post, 1e-300)
    M_all[sel] = M_new
    u_edge = edge_position_uncertainty(surf, mask, x_mm, M_all, h_mm)[sel]
    u_new = u_gci + u_edge + u_env + TRUNCATE_LOSS * np.abs(M_new)
    rows, cols = np.nonzero(mask)
    r, c = rows[sel], cols[sel]
    diffuse = np.nan_to_num(M_new * post[sel], nan=0.0, posinf=0.0, neginf=0.0)
    lit, dif, unc = ref.lit.copy(), ref.diffuse.copy(), ref.uncertainty.copy()
    lit[r, c] = diffuse + ref.specular[r, c]
    dif[r, c] = diffuse
    unc[r, c] = u_new * post[sel]
    out = Reference(lit, dif, ref.specular.copy(), ref.mask.copy(), dict(ref.meta), ref.position.copy(), unc)
    finest = h_mm * 2.0 ** -int(depth.max())
    out.meta["refined"] = {"pixels": int(sel.sum()), "halvings": {str(float(v)): int(d) for v, d in zip(variances, depth)},
                           "seconds": time.perf_counter() - t0,
                           "env_factor": int(env_factor),
                           "note": REFINE_NOTE.format(n=int(sel.sum()), h1=h_mm / 2, h=h_mm, hn=finest, f=int(env_factor),
                                                       own=REFINE_ENV_OWN_SIGMA, rays=ENV_DIFFUSE_RAYS * int(env_factor))}
    report("refine", 1.0)
    return out


# -- the viewer's ground truth: progressive, the view-independent work kept ------------------------
#
# The diffused surface radiance does not depend on the camera: the source elements and their E A
# (every shadow ray towards the lights, the bulk of a truth's time) depend on the scene, the lights and
# the maps only, and the profile only weighs them. A TruthSession keeps them per (scene, lights,
# specular, mix, energy, h) over the *whole* surface, so an orbit re-casts the camera rays, the
# specular and the gather at the new pixels, and a profile change only the gather; a light change
# rebuilds them. The pixels come in stages (every 4th pixel in x and y, every 2nd, all), each a
# Reference whose mask holds the pixels done so far, so the figures and the heat map refine while the
# user looks; before the whole-surface sources exist, a coarse stage (visible part only, elements of
# COARSE_H_MM, every 4th pixel) gives a first figure in seconds (coarse: a little low on the head). The final stage's element set is the
# whole surface (compute_reference keeps only what reaches a visible pixel): the same integral, its
# clusters of the widest Gaussians grouped differently (figures within a few 0.01 %).

COARSE_H_MM = 2.0
# the truth session's lattices for the diffusion's wide Gaussians (TruthSession.field; issue 34): the
# spacing over sigma, chosen by the convergence check in notes/artist.md (the figure moves < 10 % of
# itself when it is halved)
FIELD_RATIO = 1.0
LATTICE_PAYS = 2.0  # a lattice is used where its spacing is >= 2 x the pixels' (lattice_gaussians)
LATTICE_SAFETY = 4.0  # the lattices' uncertainty: 4 x the curvature bound measured nearby (lattice_uncertainty)
LATTICE_WINDOW = 9  # ... at the judge pixels (every 4th in x and y) of the pixel's 9 x 9 neighbourhood
# where that uncertainty is a large part of the view's, the pixels gather the lattices' Gaussians exactly
# (TruthSession.lattice_refine): until what is left is <= LATTICE_TARGET of the view's RMS per channel,
# at most LATTICE_REFINE_MAX of the pixels
LATTICE_TARGET = 0.005
LATTICE_REFINE_MAX = 0.25
LATTICE_UNCERTAINTY_NOTE = ("per pixel: the surface lattices' interpolation error, measured where the first stage "
                            "gathered every Gaussian exactly (every 4th pixel in x and y) and scaled to the pixel's "
                            "whole lattice cell (error ~ curvature x sum_i l_i |x - x_i|^2; the largest curvature of "
                            "the 9 x 9 neighbourhood's judges, x 4) + 5e-5 M (truncation), times C^(1-mix) "
                            "rho_dt(N.V); where that would exceed 0.5 % of the view's RMS, the pixels with the "
                            "largest part gather the wide Gaussians exactly (no interpolation error; at most a "
                            "quarter of the pixels); not the element size's part (skinviewer reference states that)")
STRIDES = (4, 2, 1)
ENV_POINT_K = 3.0      # the pixels' environment estimates: K standard errors (env_point_uncertainty)
ENV_UNCERTAINTY_NOTE = ("; with an environment: the Monte Carlo error of its irradiance estimated at the pixels' "
                        "own points (3 standard errors, each at least the view's median relative one, times the "
                        "weight of the Gaussians that read the pixel's own E A)")


def env_point_uncertainty(diff: gt.Diffusion, se: np.ndarray, e_env: np.ndarray, sel: np.ndarray) -> np.ndarray:
    """The uncertainty (N, 3) of M at the pixels ``sel`` from the environment's irradiance estimated at
    the pixels' own points (``Surface.env_direct``: standard error ``se``, value ``e_env``, both x C^mix).
    That E A is read by the delta and the exact (narrow) Gaussians (Diffusion.exitance's ``ea_here``),
    so their weights carry its error. A point's standard error comes from ENV_BATCHES batches (3 degrees
    of freedom) and is 0 where no sample was blocked, so each is taken as at least the view's median
    standard error relative to max(E, the median E), times that max: ENV_POINT_K x sqrt(se^2 + (median
    relative se x max(E, median E))^2). Measured on the default head (32x32 and 64x64 at detail 0, 96x96
    at detail 1) against estimates with 4x the rays: the difference is inside the two estimates' stated
    uncertainties at 99.3-99.8 % of the pixels (2 standard errors: 98 %; the plain standard error x 3: 83 %)."""
    out = np.zeros_like(se)
    if not sel.any():
        return out
    ref = np.maximum(e_env[sel], float(np.median(e_env[sel].sum(1))) / 3.0)  # a channel's median
    rel = np.median(se[sel] / np.maximum(ref, 1e-300), axis=0)
    here = np.zeros(3)
    for v, w in zip(diff.v, diff.w):
        if diff.method(float(v))[0] in ("delta", "exact"):
            here += np.asarray(w, np.float64)
    out[sel] = ENV_POINT_K * np.sqrt(se[sel] ** 2 + (rel[None] * ref) ** 2) * here[None]
    return out


# truth version 9's (and the session's before session 11) check of the environment's interpolation, kept for
# bench_ruler's comparison: the mean of the nearest checks, blind to a far face a wide Gaussian reads
ENV_EL_STRIDE = 8   # the source elements' interpolated environment is checked at every 8th triangle
ENV_EL_NEAR = 8     # ... and a pixel takes the ratio of its ENV_EL_NEAR nearest checks

def env_interpolation_checks(surf: Surface, mix: float, energy: bool, stride: int = ENV_EL_STRIDE,
                             tri: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The environment's interpolation at the source elements, checked (issue 34): at a random point of
    every ``stride``-th triangle (seeded: the same points whichever view asks), the environment's
    irradiance as the elements read it (Surface.env_irradiance: linear between three estimates inside
    the triangle) against an estimate at the point itself (Surface.env_direct, independent rays), both
    x C^mix; ``tri``: only those of them. Returns (points mm (S, 3), |interpolated - own| (S, 3)). The
    difference holds both estimates' Monte Carlo error too (it is stated, not subtracted)."""
    if surf.env is None:
        return np.zeros((0, 3)), np.zeros((0, 3))
    every = np.arange(0, len(surf.F), max(int(stride), 1))
    bary = np.random.default_rng(2718).dirichlet(np.ones(3), len(every))  # per checked triangle
    if tri is not None:  # only these of the checked triangles (tests: a part of the surface)
        keep = np.isin(every, tri)
        every, bary = every[keep], bary[keep]
    tri = every
    a = surf.attributes(tri, bary)
    cm = _safe_pow(a["C"], mix)
    interp = surf.env_irradiance(tri, bary, energy) * cm
    own, _ = surf.env_direct(a, energy, seed=2718)
    return a["P"] * surf.mm, np.abs(interp - own * cm)


def env_element_uncertainty(checks: tuple[np.ndarray, np.ndarray], x_mm: np.ndarray,
                            w_read: np.ndarray, here: np.ndarray | None = None, near: int = ENV_EL_NEAR
                            ) -> np.ndarray:
    """The uncertainty (N, 3) of M at points ``x_mm`` from the environment interpolated at the source
    elements: the mean |dE| of the ``near`` nearest checks (env_interpolation_checks) -- a Gaussian's
    sum over elements (unit weight) is off by at most the mean of its elements' |dE| -- or, if larger,
    ``here`` (N, 3): the same check at each point itself, |interpolated - own| (the session has both
    there: the narrow Gaussians read the elements next to the pixel, where a fold's error is), times
    ``w_read`` (3,), the weight of the Gaussians that read the elements (all but the delta's, which
    reads the pixel's own estimate). Absolute, not relative to E A: in a crease the interpolation can
    exceed the value itself many times (a ratio times M blew up there: +- 35 % on the head's blue);
    measured in notes/truth.md."""
    pos, d = checks
    out = np.zeros((len(x_mm), 3))
    if len(pos) and len(x_mm):
        from scipy.spatial import cKDTree
        k = min(int(near), len(pos))
        _, nn = cKDTree(pos).query(x_mm, k=k)
        out = d[nn.reshape(len(x_mm), k)].mean(1)
    if here is not None:
        out = np.maximum(out, here)
    res: np.ndarray = out * np.asarray(w_read, np.float64)[None]
    return res


ENV_INTERP_NOTE = ("; with an environment: its interpolation between the three estimates of each triangle, which "
                   "the pixel and the source elements read: each triangle's linear field at its three corners "
                   "against an estimate at the corner itself (its mean |difference|), through the same Gaussians "
                   "as the light (the diffusion sum of that bound over the elements), and at the pixel itself "
                   "|interpolated - own| for the element under it")


ENV_INTERP_SESSION_NOTE = ("; from the whole surface's stage on, the environment interpolated between the three "
                           "estimates of each triangle, which the source elements read: each triangle's linear field "
                           "at its three corners against an estimate at the corner itself (its mean |difference|), "
                           "through the same Gaussians as the light but the delta (which reads the pixel's own "
                           "estimate)")
ENV_INTERP_H_MM = 1.0  # the interpolation bound's elements: its field is constant over each mesh triangle (~2.8 mm)


def env_corner_checks(surf: Surface, tri: np.ndarray, mix: float, energy: bool, seed: int = 2718) -> np.ndarray:
    """The environment's interpolation error over each of the triangles ``tri`` (issue 30): the mean over
    its three corners of |its linear field there (extrapolated from the three estimates inside it) -
    an estimate at the corner itself| (Surface.env_direct, independent rays, seeded; one per mesh vertex,
    shared by the triangles around it, its shadow rays along the vertex's area-weighted face normal), x
    C^mix there. For a quadratic irradiance the corners' mean is 1.6-4.9x the triangle's mean |error|
    (never less: the three estimates sit at a degree-2 quadrature's points, so the corners are where the
    linear field is furthest off); a single random point of the triangle is below a third of it 10 % of
    the time. Returns (T, 3); without an environment zeros."""
    out = np.zeros((len(tri), 3))
    if surf.env is None or len(tri) == 0:
        return out
    tri = np.asarray(tri, np.int64)
    verts = np.unique(surf.F[tri])
    own = np.zeros((len(surf.P), 3))
    own[verts] = surf.env_direct(surf._env_points("coarse", verts), energy, seed=seed)[0]
    corner = np.broadcast_to(np.eye(3), (len(tri), 3, 3)).reshape(-1, 3)
    t3 = np.repeat(tri, 3)
    lin = surf.env_irradiance(t3, corner, energy)  # the triangle's own linear field at its corners
    cm = _safe_pow(surf.attributes(t3, corner)["C"], mix)
    d = np.abs(lin - own[surf.F[tri].ravel()]) * cm
    res: np.ndarray = d.reshape(len(tri), 3, 3).mean(1)
    return res


def env_interpolation_sources(surf: Surface, mix: float, energy: bool, h_mm: float = DEFAULT_H_MM
                              ) -> tuple[gt.Elements, float]:
    """The environment's interpolation bound as source elements (view-independent): each triangle whose
    estimates the truth made carries its corners' mean |interpolated - own| (env_corner_checks) on
    elements of max(``h_mm``, ENV_INTERP_H_MM) (constant over a triangle: no finer ones needed; no
    shadow-edge cut: E is smooth). Returns (elements, their edge mm); without an environment none."""
    made = np.unique(np.nonzero(surf.env_done["full"])[0] // 3) if surf.env is not None else np.zeros(0, np.int64)
    d_tri = np.zeros((len(surf.F), 3))
    d_tri[made] = env_corner_checks(surf, made, mix, energy)
    keep = np.zeros(len(surf.F), bool)
    keep[made] = True
    tri_mm = surf.P[surf.F] * surf.mm
    h_mm = max(float(h_mm), ENV_INTERP_H_MM)
    vpar, vbary, elem = gt.subdivide(tri_mm, h_mm, keep)  # as build_diffusion's (no shadow-edge cut: E is smooth)
    corners = np.einsum("vk,vkd->vd", vbary, tri_mm[vpar])[elem]
    return gt.Elements(corners, d_tri[vpar[elem[:, 0]]]), h_mm


def env_interpolation_here(surf: Surface, a: dict[str, Any], mix: float, energy: bool) -> np.ndarray:
    """The environment's interpolation error at receivers ``a`` themselves (N, 3): |interpolated - an
    estimate at the point| (Surface.env_direct, seeded) x C^mix, what the element under a pixel carries
    when the pixel reads the interpolated environment."""
    own, _ = surf.env_direct(a, energy, seed=4242)
    res: np.ndarray = np.abs(surf.env_irradiance(a["tri"], a["bary"], energy) - own) * _safe_pow(a["C"], mix)
    return res


def env_interpolation_exitance(bound: gt.Diffusion, x_mm: np.ndarray, here: np.ndarray | None,
                               cancelled: Callable[[], bool] | None = None) -> np.ndarray:
    """The environment's interpolation bound (N, 3) of M at ``x_mm``: the diffusion sum ``bound`` (over
    env_interpolation_sources' elements, the truth's Gaussians). ``here`` (N, 3): the points' own
    |interpolated - own| (env_interpolation_here), for a truth whose pixels read the interpolated
    environment (compute_reference): the element under the pixel carries it. None: the pixels read
    their own estimate (the session's default; its error env_point_uncertainty's), so every Gaussian but
    the delta, which reads nothing else."""
    if len(bound.el.area) == 0:  # no estimates made: nothing interpolated
        return np.zeros((len(x_mm), 3))
    if here is not None:
        return bound.exitance(x_mm, here, cancelled=cancelled)
    return bound.exitance(x_mm, None, cancelled=cancelled,
                          only={k for k, v in enumerate(bound.v) if bound.method(float(v))[0] != "delta"})


def env_interpolation_uncertainty(surf: Surface, a: dict[str, Any], variances: np.ndarray, weights: np.ndarray,
                                  mix: float, energy: bool, h_mm: float = DEFAULT_H_MM) -> np.ndarray:
    """compute_reference's stated error (N, 3) of M at receivers ``a`` from the environment read linearly
    between three estimates inside each mesh triangle (issue 30). M is linear in the elements' E A with
    non-negative Gaussian weights, so its error is at most the same diffusion sum of |dE A|: the
    elements of env_interpolation_sources (each triangle's corner checks) through the truth's own
    Gaussians, and the element under the pixel (the delta, the exact Gaussians) the pixel's own
    |interpolated - own| (env_interpolation_here). Weighting the checks by what each Gaussian reads
    matters where a Gaussian reaches another surface: across a 2 mm blade red's wide Gaussians read the
    far face, whose error a nearest-checks mean never saw (session 11). Without an environment: zeros."""
    out = np.zeros((len(a["P"]), 3))
    if surf.env is None or len(out) == 0:
        return out
    el, h = env_interpolation_sources(surf, mix, energy, h_mm)
    here = env_interpolation_here(surf, a, mix, energy)
    return env_interpolation_exitance(gt.Diffusion(el, variances, weights, h), a["P"] * surf.mm, here)


def sources_key(s: Settings, h_mm: float) -> str:
    """What the source elements' E A depend on: not the camera, the render size or the profile."""
    from skinviewer.engine.renderer import Renderer
    d = s.model_dump(mode="json")
    parts = {"v": VERSION, "scene": Renderer.scene_key(s), "back_faces": s.scene.back_faces, "lights": d["lights"],
             "specular": d["specular"], "mix": s.deon.mix, "energy": s.deon.energy_conservation, "h": h_mm}
    return hashlib.sha1(json.dumps(parts, sort_keys=True).encode()).hexdigest()


@dataclass
class Partial:
    """One stage of a progressive truth: ``reference.mask`` holds the pixels computed so far."""
    reference: Reference
    stage: str
    fraction: float  # of the visible pixels
    final: bool
    seconds: float  # since the start of this truth


class TruthSession:
    """Ground truths for an interactive session (the viewer's Accuracy window): progressive stages, the
    view-independent sources kept across camera and profile changes, the last ``capacity`` truths kept."""

    def __init__(self, h_mm: float = DEFAULT_H_MM, coarse_h_mm: float = COARSE_H_MM, capacity: int = 6,
                 source_sets: int = 2, field_ratio: float | None = FIELD_RATIO, env_at_pixels: bool = True):
        self.h_mm, self.coarse_h_mm = float(h_mm), float(coarse_h_mm)
        # the environment's irradiance estimated at the pixels' own points, its error stated (issue 34);
        # False: interpolated there as at the source elements (an orbit's pixels cost nothing more, but
        # the interpolation's error, ~3 % RMS of the environment's part, is in no stated uncertainty)
        self.env_at_pixels = bool(env_at_pixels)
        # each wide Gaussian of the diffusion on a surface lattice of spacing field_ratio x sigma, kept
        # across views (an orbit interpolates it at its new hit points); None: every pixel gathers it
        self.field_ratio = None if not field_ratio else float(field_ratio)
        self.capacity, self.source_sets = int(capacity), int(source_sets)
        self._scene: tuple[str, tuple[MeshData, float]] | None = None
        self._surface: tuple[str, Surface] | None = None
        self._sources: dict[str, tuple[gt.Elements, gt.PointSources]] = {}
        # per source set: the Diffusion structures over the whole surface (cluster levels, KD-tree,
        # edge frames, source grids: most of an orbit's time when rebuilt for every view; issue 34)
        self._structures: dict[str, dict[str, Any]] = {}
        self.recent: dict[str, Reference] = {}  # full key -> final truth, oldest first
        self.builds = 0  # whole-surface source sets built (tests: an orbit builds none)
        self.refined = 0  # pixels of the last final stage that gathered the lattices' Gaussians exactly

    # -- what is kept -----------------------------------------------------------------------------
    def surface(self, s: Settings) -> Surface:
        from skinviewer.engine.renderer import Renderer
        skey = json.dumps(Renderer.scene_key(s), sort_keys=True, default=str)
        if self._scene is None or self._scene[0] != skey:
            self._scene = (skey, load_scene(s))
            self._surface = None
        d = s.model_dump(mode="json")
        key = json.dumps([skey, s.scene.back_faces, d["lights"], d["specular"]], sort_keys=True)
        if self._surface is None or self._surface[0] != key:
            mesh, mm = self._scene[1]
            self._surface = (key, Surface(mesh, mm, s))
        return self._surface[1]

    def _whole_sources(self, surf: Surface, s: Settings, report: Callable[[str, float], None],
                       check: Callable[[], bool]) -> tuple[gt.Elements, gt.PointSources]:
        key = sources_key(s, self.h_mm)
        hit = self._sources.pop(key, None)
        if hit is None:
            # every element of the surface, cut along cast-shadow edges as compute_reference's (issue 34:
            # the session's truth used to keep the corners' mean there, the version-4 truth)
            whole = build_diffusion(surf, None, self.h_mm, np.ones(1), np.ones((1, 3)), s.deon.mix,
                                    s.deon.energy_conservation, report=lambda st, f: report(f"surface {st}", f),
                                    check=check)
            assert whole.points is not None  # build_diffusion always gives the beams' point sources
            hit = (whole.el, whole.points)
            self.builds += 1
        self._sources[key] = hit  # most recent last
        self._structures[key] = self._structures.pop(key, {})
        while len(self._sources) > self.source_sets:
            old = next(iter(self._sources))
            self._sources.pop(old)
            self._structures.pop(old, None)
        return hit

    def field(self, surf: Surface, shared: dict[str, Any], variance: float) -> gt.SurfaceField:
        """The exitance of one wide Gaussian (unit weights) of the source set on its surface lattice,
        spacing ``field_ratio`` x sigma: kept with the source set's structures (dropped with them),
        shared by every profile that has this variance (a weight edit re-uses it)."""
        fields = shared.setdefault("fields", {})
        h = float(self.field_ratio or 1.0) * math.sqrt(variance)
        key = (round(float(variance), 12), round(h, 12))
        f: gt.SurfaceField | None = fields.pop(key, None)
        if f is None:
            f = gt.SurfaceField(surf.P[surf.F] * surf.mm, h)
        fields[key] = f  # most recent last
        while len(fields) > 16:
            fields.pop(next(iter(fields)))
        return f

    def fields_evaluated(self, s: Settings) -> int:
        """Lattice points whose wide Gaussians were evaluated, over the source set of ``s`` (tests: an
        orbit evaluates only those its new pixels need)."""
        fields = self._structures.get(sources_key(s, self.h_mm), {}).get("fields", {})
        return sum(f.evaluated for f in fields.values())

    def lattice_gaussians(self, diff: gt.Diffusion, footprint_mm: float) -> list[int]:
        """The Gaussians kept on surface lattices for pixels ``footprint_mm`` apart on the surface: the
        wide ones (Diffusion.is_local false: sigma above the elements, smooth over sigma) whose lattice
        (spacing field_ratio x sigma) is at least LATTICE_PAYS x as coarse as the pixels -- a finer one
        costs more lattice points than pixels (a lattice is never coarser than the mesh's triangles, and
        the judge's checks come on top), and another view shares few of its cells (measured: issue 34's
        notes, 256x256: the two widest Gaussians on lattices made an orbit 2x slower than per pixel)."""
        if not self.field_ratio:
            return []
        if diff.points is not None and len(diff.points.position):
            # a beam's point sources make each wide Gaussian's field peak at the sigma scale, where a
            # lattice of spacing sigma is off by ~1/8 of the peak (its stated error as large as a
            # technique's figure, measured on the laser): such scenes are gathered per pixel
            return []
        return [k for k, v in enumerate(diff.v) if not diff.is_local(v) and np.any(diff.w[k] > 0)
                and self.field_ratio * math.sqrt(v) >= LATTICE_PAYS * footprint_mm]

    def _lattice_exitance(self, diff: gt.Diffusion, surf: Surface, shared: dict[str, Any], ks: list[int],
                          tri: np.ndarray, bary: np.ndarray, progress: Callable[[float], None] | None,
                          check: Callable[[], bool]) -> np.ndarray:
        """sum over Gaussians ``ks`` of w_k M_k at surface points (tri, bary), each M_k interpolated
        linearly from its lattice after evaluating the lattice points not done yet: an orbit evaluates
        only the surface it has not seen before."""
        M = np.zeros((len(tri), 3))
        for n, k in enumerate(ks):
            v = float(diff.v[k])
            f = self.field(surf, shared, v)
            ids, w = f.locate(tri, bary)
            need = f.missing(ids)
            if len(need):
                vt, vb = f.vertex_points(need)
                xv = surf.attributes(vt, vb)["P"] * surf.mm
                one = gt.Diffusion(diff.el, [v], np.ones((1, 3)), diff.h, diff.points, shared=shared)
                f.store(need, one.exitance(xv, None, cancelled=check))
            M += diff.w[k] * f.interpolate(ids, w)
            if progress is not None:
                progress((n + 1) / len(ks))
        return M

    def structures_built(self, s: Settings) -> dict[str, int]:
        """What the diffusion over ``s``'s source set has built so far, by kind (cluster levels, KD-tree,
        edge frames, radii, source grids): an orbit or a profile edit re-using the set adds nothing."""
        return dict(self._structures.get(sources_key(s, self.h_mm), {}).get("built", {}))

    def has_sources(self, s: Settings) -> bool:
        return sources_key(s, self.h_mm) in self._sources

    def _remember(self, key: str, ref: Reference) -> None:
        self.recent.pop(key, None)
        self.recent[key] = ref
        while len(self.recent) > self.capacity:
            self.recent.pop(next(iter(self.recent)))

    # -- the truth ------------------------------------------------------------------------------------
    def progressive(self, s: Settings, progress: Callable[[str, float], None] | None = None,
                    cancelled: Callable[[], bool] | None = None) -> Iterator[Partial]:
        """Yield :class:`Partial` stages of the truth of ``s``, the last with ``final`` True."""
        report = progress or (lambda stage, f: None)
        check = cancelled or (lambda: False)
        t0 = time.perf_counter()
        key = cache_key(s, self.h_mm) + "-session" + (f"-field{self.field_ratio:g}" if self.field_ratio else "") \
            + ("" if self.env_at_pixels else "-env-interpolated")
        if key in self.recent:
            ref = self.recent.pop(key)
            self.recent[key] = ref
            yield Partial(ref, "recent", 1.0, True, time.perf_counter() - t0)
            return
        variances, weights = profile_of(s)
        mix, energy = s.deon.mix, s.deon.energy_conservation
        report("camera rays", 0.0)
        surf = self.surface(s)
        env_px = surf.env is not None and self.env_at_pixels
        mask, tri, bary, eye = camera_hits(surf, s)
        a = surf.attributes(tri, bary)
        x_mm = a["P"] * surf.mm
        # E A at the pixels themselves, per stage (the coarse stage with the coarse environment)
        ea_here = np.zeros((len(x_mm), 3))
        has_ea = np.zeros(len(x_mm), bool)
        # the environment's part at the pixels' own points (issue 34: not interpolated over the source
        # triangles), its standard error (ea_se) and value (ea_env) for the stated uncertainty
        ea_se, ea_env = np.zeros((len(x_mm), 3)), np.zeros((len(x_mm), 3))

        def ea_at(sel: np.ndarray) -> np.ndarray:
            todo = sel & ~has_ea
            if todo.any():
                sub = {k: v[todo] for k, v in a.items()}
                if not env_px:
                    ea_here[todo] = surf.irradiance(sub, mix, energy)
                else:  # seeded by the stage's pixel count: an orbit draws what a fresh session draws
                    ea_here[todo], ea_se[todo] = surf.irradiance_at_points(sub, mix, energy, seed=int(todo.sum()))
                    ea_env[todo] = ea_here[todo] - surf.irradiance(sub, mix, energy, env_level="none")
                has_ea[todo] = True
            out: np.ndarray = ea_here[sel]
            return out

        def u_env(d: gt.Diffusion, sel: np.ndarray) -> np.ndarray:
            """The stated uncertainty of M from the pixels' environment estimates (env_point_uncertainty)."""
            return env_point_uncertainty(d, ea_se, ea_env, sel) if env_px \
                else np.zeros((len(x_mm), 3))
        # view-dependent: eq. (34) rho_dt(N.V) and C^(1 - mix), and the specular (eq. 35)
        V = eye[None] - a["P"]
        V /= np.maximum(np.linalg.norm(V, axis=1), 1e-300)[:, None]
        N = a["N"] * np.where((a["Ng"] * V).sum(1) < 0, -1.0, 1.0)[:, None]
        av = {**a, "N": N}
        rho_v = surf.rho_dt((N * V).sum(1), av["m"], av["rho"]) if energy else np.ones(len(V))
        post = _safe_pow(av["C"], 1.0 - mix) * rho_v[:, None]
        # the specular per stage too (the environment's samples seeded by the stage: a fresh session and
        # an orbit in an old one draw the same)
        spec = np.zeros((len(V), 3))
        has_spec = np.zeros(len(V), bool)

        def spec_at(sel: np.ndarray, seed: int) -> None:
            todo = sel & ~has_spec
            if todo.any():
                spec[todo] = surf.specular({k: v[todo] for k, v in av.items()}, V[todo],
                                           np.random.default_rng((4242, seed)))
                has_spec[todo] = True
        H, W = mask.shape
        pix = np.flatnonzero(mask.ravel())
        rows, cols = pix // W, pix % W
        n = max(len(pix), 1)

        def image(M: np.ndarray, done: np.ndarray, stage: str, h_mm: float, final: bool,
                  u_M: np.ndarray | None = None, coarse: bool = False) -> Partial:
            if coarse:  # the first figure: the environment's specular with ENV_COARSE_SPEC_RAYS, not kept
                spec[done] = surf.specular({k: v[done] for k, v in av.items()}, V[done], np.random.default_rng(4241),
                                           ENV_COARSE_SPEC_RAYS)
            else:
                spec_at(done, int(done.sum()))
            diffuse = M * post
            imgs = []
            for arr in (diffuse + spec, diffuse, spec, a["P"]) + (() if u_M is None else (u_M * post,)):
                img = np.zeros((H * W, 3))
                img[pix[done]] = np.nan_to_num(arr[done], nan=0.0, posinf=0.0, neginf=0.0)
                imgs.append(img.reshape(H, W, 3))
            m = np.zeros(H * W, bool)
            m[pix[done]] = True
            sec = time.perf_counter() - t0
            meta = {"key": key, "version": VERSION, "h_mm": h_mm, "pixels": int(done.sum()), "stage": stage,
                    "fraction": float(done.sum() / n), "seconds": {"total": sec}, "cached": False,
                    "mm_per_unit": surf.mm, "session": True, "visible_mask": mask, "field_ratio": self.field_ratio}
            if u_M is not None:
                meta["uncertainty"] = LATTICE_UNCERTAINTY_NOTE + (ENV_UNCERTAINTY_NOTE if env_px else "") \
                    + ((ENV_INTERP_SESSION_NOTE if env_px else ENV_INTERP_NOTE) if surf.env is not None else "")
            return Partial(Reference(imgs[0], imgs[1], imgs[2], m.reshape(H, W), meta, imgs[3],
                                     imgs[4] if u_M is not None else None), stage, float(done.sum() / n), final, sec)

        first = np.zeros(len(pix), bool)
        first[(rows % STRIDES[0] == 0) & (cols % STRIDES[0] == 0)] = True
        if not self.has_sources(s):  # a first figure before the whole surface's sources exist
            # the environment's coarse estimate (ENV_COARSE_RAYS per vertex) for the sources and pixels
            diff = build_diffusion(surf, x_mm[first], self.coarse_h_mm, variances, weights, mix, energy,
                                   report=lambda st, f: report(f"coarse {st}", f), check=check, env_level="coarse")
            M = np.zeros((len(pix), 3))
            ea_c = surf.irradiance({k: v[first] for k, v in a.items()}, mix, energy, "coarse")
            M[first] = diff.exitance(x_mm[first], ea_c, cancelled=check)
            yield image(M, first, f"coarse ({self.coarse_h_mm:g} mm elements, 1/{STRIDES[0] ** 2} of the pixels)",
                        self.coarse_h_mm, False, coarse=True)
            # then the same pixels at full resolution from the sources that reach them only (as
            # compute_reference's): the environment's estimates they need (most of a first truth's time)
            # are the whole surface's, kept; the whole-surface stage below computes these pixels again
            # (the same integral, clustered differently: a truth does not depend on the session's past)
            diff_v = build_diffusion(surf, x_mm[first], self.h_mm, variances, weights, mix, energy,
                                     report=lambda st, f: report(f"visible {st}", f), check=check)
            M = np.zeros((len(pix), 3))
            M[first] = diff_v.exitance(x_mm[first], ea_at(first), cancelled=check)
            u_first = u_env(diff_v, first)
            del diff_v
            yield image(M, first, f"1/{STRIDES[0] ** 2} of the pixels (the sources that reach them)", self.h_mm, False,
                        u_first + TRUNCATE_LOSS * np.abs(M))
        el, pts = self._whole_sources(surf, s, report, check)
        shared = self._structures[sources_key(s, self.h_mm)]
        if surf.env is not None and "env_interp" not in shared:  # view-independent: kept with the sources
            report("environment checks", 0.0)
            # the bound's elements and its Diffusion's structures (an orbit builds none of them again)
            shared["env_interp"] = (*env_interpolation_sources(surf, mix, energy, self.h_mm), {})
            report("environment checks", 1.0)
        u_interp, has_interp = np.zeros((len(x_mm), 3)), np.zeros(len(x_mm), bool)

        def u_env_el(sel: np.ndarray) -> np.ndarray:
            """The stated uncertainty of M from the environment interpolated at the source elements, as
            compute_reference's (env_interpolation_uncertainty: each triangle's corner checks through the
            same Gaussians), per pixel once. With the environment at the pixels' own points the delta reads
            the pixel's estimate (its error: env_point_uncertainty), every other Gaussian the elements;
            interpolated at the pixels too, the element under the pixel carries its own check."""
            todo = sel & ~has_interp
            if surf.env is not None and todo.any():
                el_i, h_i, built = shared["env_interp"]
                here = None if env_px else env_interpolation_here(surf, {k: v[todo] for k, v in a.items()}, mix, energy)
                u_interp[todo] = env_interpolation_exitance(gt.Diffusion(el_i, variances, weights, h_i, shared=built),
                                                            x_mm[todo], here, check)
                has_interp[todo] = True
            out = np.zeros((len(x_mm), 3))
            out[sel] = u_interp[sel]
            return out
        diff = gt.Diffusion(el, variances, weights, self.h_mm, pts, shared=shared)
        footprint = pixel_footprint_mm(pix, W, x_mm)
        M = np.zeros((len(pix), 3))
        # the final stage's lattice Gaussians, and their exact per-pixel sum at the first stage's pixels
        # (every STRIDES[0]-th pixel): the final stage also interpolates them there, and the difference
        # is the lattice's interpolation error, measured -- the uncertainty it states (lattice_uncertainty)
        lat_final = self.lattice_gaussians(diff, footprint)
        exact_lat = {k: np.zeros((len(pix), 3)) for k in lat_final}
        M_wide = np.zeros((len(pix), 3))  # the lat_final Gaussians' part of M, gathered or interpolated
        self.refined = 0
        done = np.zeros(len(pix), bool)
        U = np.zeros((len(pix), 3))
        for stride in STRIDES:
            sel = (rows % stride == 0) & (cols % stride == 0) & ~done
            final = stride == 1
            if sel.any():
                step = functools.partial(report, f"diffusion 1/{stride * stride}")
                # this stage's pixels are ``stride`` pixels apart: a lattice pays only if coarser than that;
                # the first stage gathers every Gaussian per pixel (the lattices' judge)
                lat = [] if stride == STRIDES[0] else self.lattice_gaussians(diff, footprint * stride)
                per_pixel = [k for k in range(len(diff.v)) if k not in lat]
                judged = [k for k in per_pixel if k in lat_final]
                rest = [k for k in per_pixel if k not in judged]
                ea_sel = ea_at(sel)
                M[sel] = diff.exitance(x_mm[sel], ea_sel, progress=step, cancelled=check, only=rest)
                for k in judged:
                    exact_lat[k][sel] = diff.exitance(x_mm[sel], ea_sel, cancelled=check, only={k})
                    M[sel] += exact_lat[k][sel]
                    M_wide[sel] += exact_lat[k][sel]
                if lat:
                    m_lat = self._lattice_exitance(diff, surf, shared, lat, tri[sel], bary[sel], step, check)
                    M[sel] += m_lat
                    M_wide[sel] += m_lat
            done |= sel
            if final and lat_final:
                U = self.lattice_uncertainty(diff, surf, shared, lat_final, tri, bary, first, exact_lat, mask,
                                             rows, cols, ~first, check)
                # where the lattices' uncertainty dominates the view's, gather their Gaussians exactly
                # (issue 34: on the back-lit flap their +- was as large as a technique's figure)
                spec_at(done, int(done.sum()))  # as image() below: the same seed, the same samples
                ref_rms = np.sqrt(np.mean((M * post + spec) ** 2, axis=0))
                redo = self.lattice_refine(U * post, ref_rms)
                if redo.any():
                    report("lattice refinement", 0.0)
                    exact = diff.exitance(x_mm[redo], ea_at(redo), cancelled=check, only=set(lat_final))
                    M[redo] += exact - M_wide[redo]
                    U[redo] = 0.0
                    report("lattice refinement", 1.0)
                self.refined = int(redo.sum())
            part = image(M, done, "final" if final else f"1/{stride * stride} of the pixels", self.h_mm, final,
                         U + u_env(diff, done) + u_env_el(done) + TRUNCATE_LOSS * np.abs(M))
            if final:
                self._remember(key, part.reference)
            yield part

    @staticmethod
    def lattice_refine(u: np.ndarray, ref_rms: np.ndarray) -> np.ndarray:
        """The pixels (bool (N,)) whose lattice Gaussians are gathered exactly after all: those with the
        largest share of the lattices' stated uncertainty ``u`` (N, 3) in the view's relative RMS
        (rms(u) / ``ref_rms``), fewest first, until what is left is at most LATTICE_TARGET of the view's
        RMS in every channel, and never more than LATTICE_REFINE_MAX of the pixels. The stated error of
        the interpolation is tested to cover the real one; this makes it small where it would have
        qualified a figure by as much as the figure (the back-lit flap at the viewer's size: +- 4-6 %
        of the lit level, the real lattice error ~0.6-1 %)."""
        n = len(u)
        out = np.zeros(n, bool)
        if n == 0 or not np.any(u > 0):
            return out
        rel2 = (u / np.maximum(ref_rms, 1e-300)[None]) ** 2 / n   # each pixel's part of rms(u)^2 / rms^2
        order = np.argsort(-rel2.sum(1), kind="stable")
        left = rel2.sum(0) - np.concatenate([np.zeros((1, 3)), np.cumsum(rel2[order], axis=0)])  # (n + 1, 3)
        ok = np.all(left <= LATTICE_TARGET ** 2, axis=1)
        k = int(np.argmax(ok)) if ok.any() else n
        k = min(k, int(LATTICE_REFINE_MAX * n))
        out[order[:k]] = True
        return out

    def lattice_uncertainty(self, diff: gt.Diffusion, surf: Surface, shared: dict[str, Any], ks: list[int],
                            tri: np.ndarray, bary: np.ndarray, judge: np.ndarray, exact: dict[int, np.ndarray],
                            mask: np.ndarray, rows: np.ndarray, cols: np.ndarray, interpolated: np.ndarray,
                            check: Callable[[], bool]) -> np.ndarray:
        """The lattices' interpolation uncertainty (N, 3) of M at the view's pixels. A linear interpolant's
        error at x in a cell of vertices x_i is ~ 1/2 sum_i l_i (x - x_i)' H (x - x_i), i.e. c B(x) with
        B(x) = sum_i l_i |x - x_i|^2 (0 at the vertices, largest near the centre) and c the field's
        curvature there. At the ``judge`` pixels (every STRIDES[0]-th; Gaussian k gathered exactly there:
        ``exact[k]``) the error of each lattice is measured and c estimated as error / max(B(x), B_c / 4)
        (B_c: B at the cell's centroid, the floor keeps a judge next to a vertex from blowing it up); a
        pixel the lattices gave (``interpolated``) takes LATTICE_SAFETY x sum_k w_k c_k B_c of its own cell,
        c_k the largest of the judges of its LATTICE_WINDOW^2 neighbourhood (none there: the largest of
        all) -- a bound for its whole cell, whatever the pixel's place in it (a judge's place in its cell
        would otherwise alias with the lattice's period)."""
        from scipy.ndimage import maximum_filter
        H, W = mask.shape
        u = np.zeros((len(tri), 3))
        jt, jb = tri[judge], bary[judge]
        for k in ks:
            f = self.field(surf, shared, float(diff.v[k]))
            err = np.abs(self._lattice_exitance(diff, surf, shared, [k], jt, jb, None, check) / diff.w[k].max()
                         - exact[k][judge] / diff.w[k].max())  # unit weights: the Gaussian's own field
            bj, bcj = self._bubble(f, surf, jt, jb)
            curv = err / np.maximum(bj, 0.25 * bcj)[:, None]
            img = np.full((H, W, 3), -1.0)
            img[rows[judge], cols[judge]] = curv
            near = maximum_filter(img, size=(LATTICE_WINDOW, LATTICE_WINDOW, 1), mode="constant", cval=-1.0)
            c = near[rows, cols]
            c = np.where(c < 0.0, (curv.max(0) if len(curv) else np.zeros(3))[None], c)
            _, bc = self._bubble(f, surf, tri, bary)
            u += diff.w[k].max() * c * bc[:, None]
        out: np.ndarray = np.where(interpolated[:, None], LATTICE_SAFETY * u, 0.0)
        return out

    @staticmethod
    def _bubble(f: gt.SurfaceField, surf: Surface, tri: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B(x), B at the cell's centroid) for points (tri, bary) in lattice ``f`` (mm^2)."""
        ids, w = f.locate(tri, bary)
        vt, vb = f.vertex_points(ids.ravel())
        xv = np.einsum("nk,nkd->nd", vb, surf.P[surf.F[vt]] * surf.mm).reshape(len(tri), 3, 3)
        x = np.einsum("nk,nkd->nd", w, xv)
        b = (w * ((xv - x[:, None]) ** 2).sum(2)).sum(1)
        c = xv.mean(1)
        bc = ((xv - c[:, None]) ** 2).sum(2).mean(1)
        return b, bc


def pixel_footprint_mm(pix: np.ndarray, width: int, x_mm: np.ndarray) -> float:
    """The view's pixel spacing on the surface (mm): the median distance between the hit points of
    horizontally adjacent pixels (``pix``: flat indices of the hit pixels, ``x_mm`` their points)."""
    pos = np.searchsorted(pix, pix + 1)
    ok = (pos < len(pix)) & ((pix + 1) % width != 0)
    ok[ok] &= pix[pos[ok]] == pix[ok] + 1
    if not ok.any():
        return math.inf
    return float(np.median(np.linalg.norm(x_mm[pos[ok]] - x_mm[ok], axis=1)))


def sampled_rms(img: np.ndarray, ref: Reference, mask: np.ndarray, n_boot: int = 24, seed: int = 0
                ) -> tuple[np.ndarray, np.ndarray]:
    """Relative RMS per channel (physics.metrics.rel_rms) over the pixels the truth has so far, and its
    standard error as an estimate of the whole image's (bootstrap over those pixels, times the finite-
    population factor sqrt(1 - done / visible)): (rms (3,), se (3,))."""
    m = mask & ref.mask
    d = (np.asarray(img, np.float64) - ref.lit)[m] ** 2
    r = ref.lit[m] ** 2
    if len(d) == 0:
        return np.zeros(3), np.full(3, np.inf)
    rms = np.sqrt(d.sum(0) / np.maximum(r.sum(0), 1e-30))
    frac = float(ref.meta.get("fraction", 1.0))
    if frac >= 1.0:
        return rms, np.zeros(3)
    rng = np.random.default_rng(seed)
    boots = []
    for _ in range(n_boot):
        i = rng.integers(0, len(d), len(d))
        boots.append(np.sqrt(d[i].sum(0) / np.maximum(r[i].sum(0), 1e-30)))
    return rms, np.std(boots, axis=0) * math.sqrt(max(0.0, 1.0 - frac))
