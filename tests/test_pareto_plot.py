"""The bench's pareto.png: a colour and marker per technique, the RMS axis clipped at the bulk of the
points (outliers on the top edge), a legend of the knob abbreviations."""
from __future__ import annotations

import numpy as np
from PIL import Image

from skinviewer import techniques
from skinviewer.engine import bench


def test_every_technique_has_its_own_colour_and_marker():
    names = techniques.names()
    assert set(names) <= set(bench.COLORS) and set(names) <= set(bench.MARKERS)
    assert len({bench.COLORS[n] for n in names}) == len(names)
    assert len({bench.MARKERS[n] for n in names}) == len(names)


def test_the_rms_axis_is_clipped_at_the_bulk_of_the_points():
    ys = [5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 320.0]
    top = bench._clip_top(ys)
    assert 13.0 < top < 40.0  # the 320 % outlier does not flatten the rest
    assert bench._clip_top([5.0, 6.0, 7.0]) == 7.0 * 1.08  # nothing clipped when nothing stands out


def test_knob_legend_covers_the_sweep_labels():
    abbreviations = " ".join(k for k, _ in bench.KNOBS)
    for key in ("irr", "G", "sm", "pcf", "map", "it", "t-rot", "n=", "lut"):
        assert key in abbreviations


def test_pareto_png_with_outliers(tmp_path):
    res = []
    for k, n in enumerate(techniques.names()):
        for j in range(4):
            res.append(bench.Result(n, f"cfg{j}", {}, full_ms=50.0 * (k + 1) * (j + 1), camera_ms=1.0,
                                    rms=[0.05 + 0.01 * j] * 3, p99=[0.2] * 3, dssim=0.01))
    res[0].rms = [3.2] * 3  # a 320 % outlier
    bench.pareto_front(res)
    out = tmp_path / "pareto.png"
    bench.pareto_plot(res, out, title="test")
    img = np.asarray(Image.open(out).convert("RGB"))
    assert img.shape[0] > 500 and img.shape[1] > 900 and img.std() > 10
    assert list(tmp_path.iterdir()) == [out]  # atomic: nothing else left behind
