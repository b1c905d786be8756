"""Turntables (MP4 through imageio-ffmpeg, GIF through Pillow, PNG frames) and comparison sheets, at
tiny sizes: what is written is complete and readable, a cancelled or failed turntable leaves nothing."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from skinviewer.cli import main
from skinviewer.cli import sheet as sheet_cli
from skinviewer.cli import turntable as tt
from skinviewer.ground.settings import Settings, with_values

TINY = ["--size", "48x48", "--set", "deon.irradiance_size=256", "--set", "deon.tsm_size=256"]


def _frames(n: int, w: int = 48, h: int = 48):
    for i in range(n):
        img = np.zeros((h, w, 3), np.uint8)
        img[..., 0] = 60 * i
        img[h // 4: h // 2, w // 4: w // 2] = 255
        yield img


def test_orbit_turns_the_camera_or_the_lights():
    s = Settings()
    cams = tt.orbit(s, 4)
    assert [c.camera.yaw - s.camera.yaw for c in cams] == [0, 90, 180, 270]
    assert all(c.lights == s.lights for c in cams)
    lights = tt.orbit(s, 4, light_orbit=True)
    assert all(c.camera == s.camera for c in lights)
    x, y, z = s.lights[0].direction
    assert lights[1].lights[0].direction == pytest.approx((z, y, -x))  # 90 deg about +Y
    assert lights[2].lights[0].direction == pytest.approx((-x, y, -z))


@pytest.mark.parametrize("kind", ["mp4", "gif", "frames"])
def test_writers_produce_readable_complete_output(tmp_path, kind):
    out = str(tmp_path / ("spin.mp4" if kind == "mp4" else "spin.gif" if kind == "gif" else "frames/"))
    tt.write_turntable(out, _frames(5, 47, 33), fps=12)  # odd sizes: MP4 pads to even
    if kind == "mp4":
        import imageio_ffmpeg
        r = imageio_ffmpeg.read_frames(out)
        meta = next(r)
        frames = list(r)
        assert meta["size"] == (48, 34) and len(frames) == 5 and meta["fps"] == 12
    elif kind == "gif":
        im = Image.open(out)
        assert im.n_frames == 5 and im.size == (47, 33)
    else:
        names = sorted(p.name for p in (tmp_path / "frames").iterdir())
        assert names == [f"frame_{i:04d}.png" for i in range(5)]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("out", ["spin.mp4", "spin.gif", "frames/"])
def test_a_failing_render_leaves_nothing(tmp_path, out):
    def broken():
        yield from _frames(2)
        raise KeyboardInterrupt  # Ctrl-C (or the viewer's cancel) in the middle
    with pytest.raises(KeyboardInterrupt):
        tt.write_turntable(str(tmp_path / out), broken(), fps=24)
    assert list(tmp_path.iterdir()) == []


def test_bad_turntable_arguments_give_one_line(tmp_path, capsys):
    for argv, what in ((["--frames", "0"], "--frames"), (["--out", str(tmp_path / "x.avi")], ".mp4, .gif")):
        args = ["turntable", "--out", str(tmp_path / "x.gif"), *argv]
        assert main(args) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and what in err[0]
    assert list(tmp_path.iterdir()) == []


def test_turntable_renders_the_head(tmp_path, capsys):
    out = tmp_path / "spin.gif"
    assert main(["turntable", "--frames", "3", *TINY, "--out", str(out)]) == 0, capsys.readouterr().err
    im = Image.open(out)
    assert im.n_frames == 3
    frames = []
    for i in range(3):
        im.seek(i)
        frames.append(np.asarray(im.convert("RGB"), np.float64))
    assert all(f.std() > 5 for f in frames)  # the head, not an empty frame
    assert np.abs(frames[0] - frames[1]).mean() > 1  # the camera turned


def test_differing_lists_changed_settings_of_the_technique():
    s = with_values(Settings(), {"technique": "burley2", "burley2.channel_scale": [2, 1, 1], "specular.m": 0.25})
    d = sheet_cli.differing(s, 99)
    assert any(x.startswith("burley2.channel_scale") for x in d) and "specular.m=0.25" in d
    assert sheet_cli.differing(Settings()) == []


def test_sheet_lays_out_labelled_tiles(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    code = main(["sheet", "--techniques", "phong,deon", "--views", "front,back", "--no-truth", *TINY,
                 "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    img = np.asarray(Image.open(out).convert("RGB"))
    label_h = 40
    assert img.shape == (2 * (48 + label_h), 2 * 48, 3)
    for row in range(2):
        for col in range(2):
            y, x = row * (48 + label_h), col * 48
            assert img[y:y + 48, x:x + 48].std() > 5  # a render
            assert (img[y + 48:y + 48 + label_h, x:x + 48] > 150).any()  # a label
    text = capsys.readouterr().out
    assert "phong" in text and "deon" in text and " ms" in text


def test_sheet_rejects_unknown_names(tmp_path, capsys):
    assert main(["sheet", "--techniques", "deon,nope", "--out", str(tmp_path / "s.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope" in err[0]
    assert main(["sheet", "--views", "top", "--out", str(tmp_path / "s.png")]) == 2
    assert "top" in capsys.readouterr().err


def test_sheet_labels_the_error_against_a_cached_truth(tmp_path, capsys, monkeypatch):
    """With a cached ground truth of the view the tile says its RMS error (here a stand-in truth of
    uniform grey radiance: the figure is the plumbing's, not a judgement of the technique)."""
    from skinviewer.engine import reference
    calls = []

    def cached(s, *a, **k):
        calls.append(s.camera.yaw)
        h, w = s.render.height, s.render.width
        return reference.Reference(np.full((h, w, 3), 0.05), np.zeros((h, w, 3)), np.zeros((h, w, 3)),
                                   np.ones((h, w), bool))
    monkeypatch.setattr(reference, "load_cached", cached)
    _img, recs = sheet_cli.render_sheet(with_values(Settings(), {"render.width": 48, "render.height": 48,
                                                                "deon.irradiance_size": 256, "deon.tsm_size": 256}),
                                       ["phong"], ["front", "back"])
    assert calls == [0.0, 180.0]
    assert all(r["truth_rms"] is not None and 0 < r["truth_rms"] < 100 for r in recs)


def test_import_preview_renders_the_imported_profile(tmp_path, capsys):
    from skinviewer.engine import exchange as X
    asset = tmp_path / "skin.asset"
    X.export(Settings(), "hdrp", asset)
    png = tmp_path / "preview.png"
    code = main(["import", str(asset), "--preview", str(png), "--technique", "burley", "--size", "48x48"])
    assert code == 0, capsys.readouterr().err
    img = np.asarray(Image.open(png).convert("RGB"))
    assert img.shape == (48, 48, 3) and img.std() > 5


def test_frames_into_a_non_empty_folder_is_refused_before_rendering(tmp_path, capsys):
    folder = tmp_path / "frames"
    folder.mkdir()
    (folder / "keep.txt").write_text("mine")
    assert main(["turntable", "--frames", "2", *TINY, "--out", str(folder) + "/"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and "not an empty folder" in err[0]
    assert [p.name for p in folder.iterdir()] == ["keep.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames"]
