"""Issue 27, the longest frames: a pass of dependent whole-target draws (ExecuteContext.units: Gosselin's Poisson
blur, the screen-space blurs, d'Eon's separable steps) is split into a multiple of its draws, so each band is one
sub-band of one draw. With fewer bands than draws a band was one or two whole draws, and Gosselin's blur at 1024²
ran 95-126 ms bands in frames of a 90 ms budget. The split pass equals the unsplit one bit for bit."""
from __future__ import annotations

import pytest

from skinviewer.ground.settings import with_values
from skinviewer.kernel.execute import ExecuteContext
from tests.helpers import small_settings
from tests.test_tiles import same, settle

BLUR = "gosselin_blur"


def test_align_units_rounds_the_bands_up_to_a_multiple_of_the_draws(renderer):
    g = renderer.graph("phong")
    g._units["x"] = 9
    assert [g._align_units("x", n) for n in (1, 2, 5, 9, 10, 19)] == [1, 9, 9, 9, 18, 27]
    assert g._align_units("x", 500) == 126  # at most MAX_TILES (128), still a multiple of 9
    assert g._align_units("y", 5) == 5  # a pass never seen drawing units: as counted


@pytest.mark.parametrize("iterations", [1, 3])
def test_a_pass_of_draws_in_bands_runs_one_draw_s_sub_band_a_band_and_equals_the_whole(renderer, monkeypatch,
                                                                                        iterations):
    s = small_settings("head", "gosselin", size=64, **{"gosselin.iterations": iterations})
    renderer.render(s)  # whole: timed, and its draws counted
    g = renderer.graph("gosselin")
    draws = g._units[BLUR]
    assert draws == (3 if s.scene.seam_aware else 2) * iterations
    whole = {res: g.read(res).copy() for res in ("gosselin_blurred", "image")}
    seen: list[tuple[tuple[int, int], list[tuple[int, int, int]]]] = []
    real = ExecuteContext.units

    def spy(self, n):
        out = real(self, n)
        if self.pass_.name == BLUR:
            seen.append((self.tile, out))
        return out
    monkeypatch.setattr(ExecuteContext, "units", spy)
    renderer.render(with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]}))
    # a budget that needs several bands: at least as many as the draws, a multiple of them
    budget = 0.5 * g._last_ms[BLUR] / 2.5
    seen.clear()
    settle(renderer, s, budget_ms=budget)
    counts = {tile[1] for tile, _ in seen}
    assert len(counts) == 1, counts
    count = counts.pop()
    assert count >= draws and count % draws == 0, (count, draws)
    assert all(len(units) == 1 for _, units in seen), seen  # one (draw, sub-band) a band
    assert sorted(u for _, units in seen for u in units) == [
        (d, k, count // draws) for d in range(draws) for k in range(count // draws)]
    for res, arr in whole.items():
        assert same(g.read(res), arr), res
