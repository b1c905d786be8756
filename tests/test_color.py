"""physics/color.py: the sRGB decoding the renderer applies to albedo maps and the background, and the
ground truth to its albedo, against the standard's own figures and against its GLSL twin."""
from __future__ import annotations

import numpy as np
from glsl_eval import glsl_eval

from skinviewer.physics.color import srgb_to_linear


def test_srgb_decoding_matches_the_standard():
    """IEC 61966-2-1: the segments meet at (0.04045, 0.0031308); mid grey 0.5 decodes to 0.2140;
    black and white are fixed points; inputs outside [0, 1] are clamped (a tuned colour of 1.2 is white)."""
    x = srgb_to_linear([0.0, 0.04045, 0.5, 1.0, -0.5, 1.2])
    np.testing.assert_allclose(x, [0.0, 0.0031308, 0.2140, 1.0, 0.0, 1.0], atol=5e-5)
    lo = np.linspace(0.0, 0.04, 9)
    np.testing.assert_allclose(srgb_to_linear(lo), lo / 12.92, rtol=1e-12)  # the linear toe
    y = srgb_to_linear(np.linspace(0.0, 1.0, 257))
    assert np.all(np.diff(y) > 0)  # monotonic: no step at the breakpoint


def test_srgb_decoding_agrees_with_the_shader(gl_ctx):
    """shaders/lib/color.glsl's srgb_to_linear (albedo maps are decoded on the GPU in the final passes)
    gives the numpy twin's values in float32."""
    c = np.linspace(0.0, 1.0, 65)
    gpu = glsl_eval(gl_ctx, "lib/color.glsl", "vec4(srgb_to_linear(a.xyz), 0.0)", np.stack([c, c, c], -1))[:, 0]
    np.testing.assert_allclose(gpu, srgb_to_linear(c), atol=2e-6)
