"""The output pass: exposure, tone map and sRGB encoding; the GLSL curve equals passes/output.py."""
import numpy as np
import pytest

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.graph import FrameInputs, Pass, RenderGraph, TexSpec
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.passes.output import OutputPass, tone_map
from skinviewer.physics.metrics import display_encode

RAMP = np.concatenate([np.linspace(0.0, 1.0, 24), np.geomspace(1.0, 64.0, 40)]).astype(np.float32)


class Ramp(Pass):
    """An HDR ramp as the 'lit' image (alpha 1: no background)."""
    name = "ramp"
    uses_scene = False

    def reflect(self, r):
        r.output("lit", TexSpec((len(RAMP), 16), 4, "f4"))

    def execute(self, ec):
        data = np.stack([RAMP, RAMP * 0.5, RAMP * 2.0, np.ones_like(RAMP)], axis=-1)[None].repeat(16, axis=0)
        ec.output("lit").write(data.astype(np.float32).tobytes())


@pytest.mark.parametrize("mode", ["filmic", "linear"])
def test_display_curve_matches_numpy(gl_ctx, mode):
    s = with_values(Settings(), {"render.width": len(RAMP), "render.height": 16, "render.tone_map": mode,
                                 "render.exposure": 1.5, "render.check_finite": False})
    g = RenderGraph(gl_ctx, ShaderLibrary(gl_ctx), [Ramp(), OutputPass("lit")], ["image"])
    g.run(FrameInputs(s, None, 0, None, ""))
    got = g.read("image")[0, :, :3]
    lin = np.stack([RAMP, RAMP * 0.5, RAMP * 2.0], axis=-1) * 1.5
    want = display_encode(tone_map(lin, mode))
    np.testing.assert_allclose(got, want, atol=1.5 / 255)
    g.release()


def test_filmic_rolls_off_instead_of_clipping():
    x = np.array([0.5, 1.0, 2.0, 3.0, 4.0])
    f = tone_map(x, "filmic")
    assert np.all(np.diff(f) > 0) and f[-1] < 1.0  # still tells 3x from 4x over white
    assert np.all(tone_map(x, "linear")[1:] == 1.0)
    assert tone_map(np.array([0.0]), "filmic")[0] == 0.0
