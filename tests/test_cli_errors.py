"""Command-line mistakes: one line on stderr (no usage block), exit status 2, a suggestion where a
close name exists; a preset/technique conflict stated; the README's outputs ignored by git."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from skinviewer.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _err(capsys, argv) -> str:
    with pytest.raises(SystemExit) as e:
        rc = main(argv)
        raise SystemExit(rc)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "usage:" not in err, err
    return err


@pytest.mark.parametrize("argv, expect", [
    (["render"], "required: --out; e.g. --out head.png"),
    (["render", "--out", "x.png", "--camera", "30"], "--camera expects yaw,pitch"),
    (["render", "--out", "x.png", "--scene", "heads"], "did you mean 'head'?"),
    (["render", "--out", "x.png", "--techniqe", "deon"], "did you mean --technique?"),
    (["rendr", "--out", "x.png"], "unknown command 'rendr'; did you mean 'render'?"),
    (["render", "--out", "x.png", "--size", "big"], "--size expects WxH"),
])
def test_argument_errors_are_one_line_with_a_suggestion(capsys, argv, expect):
    assert expect in _err(capsys, argv)


def test_a_mistyped_setting_gets_did_you_mean(capsys, tmp_path):
    err = _err(capsys, ["render", "--out", str(tmp_path / "x.png"), "--set", "lights.0.intensty=2",
                        "--set", "deon.gausians.1.variance=0.1"])
    assert "lights.0.intensty: no such setting; did you mean lights.0.intensity?" in err
    assert "did you mean deon.gaussians.1.variance?" in err
    assert not (tmp_path / "x.png").exists()


def test_technique_and_preset_conflict_is_stated(capsys):
    from argparse import Namespace

    from skinviewer.cli.args import settings_from_args
    args = Namespace(preset=str(ROOT / "presets" / "gosselin.json"), scene=None, mesh=None, technique="ssss",
                     size=None, camera=None, assign=[])
    s = settings_from_args(args)
    assert s.technique == "ssss"
    err = capsys.readouterr().err
    assert "--technique ssss overrides the technique of preset" in err and "(gosselin)" in err
    args.technique = "gosselin"
    settings_from_args(args)
    assert capsys.readouterr().err == ""  # no conflict, no note


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout")
@pytest.mark.parametrize("path", [".venv/bin/python", "head.png", "ear.png", "passes/graph.json", "t.json",
                                  "scan.exr", "ref.npy", "bench/pareto.png", "best.json", "skin1.json",
                                  "screenshots/a.png", "spin.mp4", "lights.gif", "skin.mtlx", "frames/0001.png"])
def test_readme_outputs_are_ignored(path):
    r = subprocess.run(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT, check=False)
    assert r.returncode == 0, f"{path} is not ignored by .gitignore"


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout")
def test_shipped_files_are_not_ignored():
    for path in ("presets/deon.json", "docs/pareto.png", "skinviewer/cli/render.py"):
        assert subprocess.run(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT, check=False).returncode == 1, path
