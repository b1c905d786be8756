"""The screen-space SSS framework (seed 001 §3.1-3.2, §3.5-3.6; ../shared/design/screen_space.md §2):
shared passes every screen-space technique builds on (Jimenez 2009 ``ssss``, Jimenez 2015
``separable``, Golubev/Burley ...). A screen-space technique is

    shadow_passes() + [*screen_lighting(), <its blur passes>, CombinePass(<blurred resource>), OutputPass()]

Contract (resource names, formats and meanings are stable; all textures are render size,
float, linear HDR, GL order row 0 at the bottom):

    ss_lighting (ScreenLightingPass, view-dependent; lights, shadow maps, specular, screen.*,
                 transmittance.enabled/wrap) writes
      "ss_diffuse"   RGBA f4  rgb: diffuse irradiance  sum_lights Lc (N.L) fac_shadow  times albedo^f
                              (f = 0 post-scatter, 1 pre-scatter, screen.mix pre-and-post; seed 001 §3.6),
                              plus the Jimenez 2010 transmittance when transmittance.enabled (skin only):
                              then ss_lighting writes this sum less the transmittance to
                              "ss_diffuse_direct" and per shadow-casting light k "ss_transmitted_k"
                              (rgb: weight, a: thickness mm), and ss_transmittance
                              (ScreenTransmittancePass; the profile, translucency, form) adds it.
                              a: the SSS mask: 1 on skin, 0 on the background and on non-skin pixels
                              (regions listed in screen.non_skin_regions; no region map = all skin).
      "ss_specular"  RGBA f2  rgb: specular (Kelemen/Szirmay-Kalos, shaders/lib/specular_params.glsl),
                              a: coverage (1 mesh, 0 background) - the lit alpha.
      "ss_depth"     RGBA f4  r: linear view depth in mm (0 on the background), g, b: |d depth / dx|,
                              |d depth / dy| in mm per pixel (GL derivatives, per 2x2 quad: eq. 3.2's
                              gradient), a: coverage.
      "ss_albedo"    RGBA f2  rgb: albedo^(1-f), the post-scatter factor the combine pass applies.
    <blur passes> read ss_diffuse (+ ss_depth) and write their own resource: rgb blurred diffuse,
      a = the mask passed through. A blur must leave mask-0 pixels unchanged and never gather from
      them (shaders/lib/screen_space.glsl ss_guard_tap: such taps take the centre colour).
    ss_combine (CombinePass(source), view-independent) writes "lit" = source.rgb x ss_albedo.rgb +
      ss_specular.rgb, alpha = coverage; then the usual OutputPass("lit") writes "image".

The pass-through technique is CombinePass(DIFFUSE): no scattering at all (a Lambert + Kelemen
render in the framework's texturing), what every blur is compared against in the tests.

Units: the mesh is in mesh units, scene.mm_per_unit converts; profile variances are mm^2.
Pixel scale at depth z (mm): P / z pixels per mm with P = H / (2 tan(fov_y / 2)) (``focal_px``).
"""
from __future__ import annotations

from skinviewer.passes.screen_space.combine import CombinePass
from skinviewer.passes.screen_space.lighting import (
    ALBEDO,
    DEPTH,
    DIFFUSE,
    SPECULAR,
    ScreenLightingPass,
    ScreenTransmittancePass,
    focal_px,
    screen_lighting,
    screen_size,
)

__all__ = ["ALBEDO", "DEPTH", "DIFFUSE", "SPECULAR", "CombinePass", "ScreenLightingPass", "ScreenTransmittancePass",
           "focal_px", "screen_lighting", "screen_size"]
