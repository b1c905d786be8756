"""The wheel ships every module, shader and preset (the full trial — build, clean venv, render from
another folder — is in .ci/run; this is its fast half), and `skinviewer --version` answers."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import skinviewer
from skinviewer.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_version_is_printed(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"skinviewer {skinviewer.__version__}"


def _packages_setup_finds() -> set[str]:
    """The packages list setup.py hands setuptools, without building anything."""
    code = ("import setuptools, sys\n"
            "setuptools.setup = lambda **kw: print('\\n'.join(kw['packages']))\n"
            "exec(open('setup.py').read())\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return set(out.split())


def test_every_folder_with_code_or_data_is_a_package_of_the_wheel():
    found = _packages_setup_finds()
    wanted = {".".join(p.relative_to(ROOT).parent.parts) for p in (ROOT / "skinviewer").rglob("*.py")
              if "__pycache__" not in p.parts}
    for folder in ("shaders", "presets"):
        wanted |= {".".join(("skinviewer",) + p.relative_to(ROOT).parent.parts)
                   for p in (ROOT / folder).rglob("*") if p.is_file() and "__pycache__" not in p.parts}
    assert wanted - found == set(), "folders the wheel would leave out"
    assert all(name.startswith("skinviewer") for name in found)


def test_package_data_patterns_cover_every_shader_and_preset():
    import fnmatch
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]["package-data"]
    for folder in ("shaders", "presets"):
        patterns = data[f"skinviewer.{folder}"]
        for p in (ROOT / folder).rglob("*"):
            if p.is_file() and "__pycache__" not in p.parts:
                rel = p.relative_to(ROOT / folder).as_posix()
                # setuptools' "**/" also matches files at the top of the folder
                assert any(fnmatch.fnmatch(rel, pat) or fnmatch.fnmatch(rel, pat.removeprefix("**/"))
                           for pat in patterns), f"{folder}/{rel} matches no package-data pattern"


def test_a_shipped_preset_is_found_by_name_outside_the_checkout(tmp_path, monkeypatch):
    """An installed wheel has no presets/ folder beside the user: `--preset burley2_beyond` and the
    README's `--preset presets/burley2_beyond.json` still find the shipped one; a local file wins."""
    from skinviewer.cli import build_parser
    from skinviewer.cli.args import settings_from_args
    from skinviewer.ground.paths import presets_dir
    monkeypatch.chdir(tmp_path)
    for given in ("burley2_beyond", "presets/burley2_beyond.json"):
        args = build_parser().parse_args(["render", "--preset", given, "--out", "x.png"])
        assert args.preset == str(presets_dir() / "burley2_beyond.json")
        assert settings_from_args(args).burley2.mode == "beyond"
    (tmp_path / "presets").mkdir()
    version = json.loads((presets_dir() / "phong.json").read_text(encoding="utf-8"))["schema_version"]
    (tmp_path / "presets" / "burley2_beyond.json").write_text(
        json.dumps({"schema_version": version, "technique": "phong"}), encoding="utf-8")
    args = build_parser().parse_args(["render", "--preset", "presets/burley2_beyond.json", "--out", "x.png"])
    assert settings_from_args(args).technique == "phong"
    args = build_parser().parse_args(["render", "--preset", "no_such_preset", "--out", "x.png"])
    assert args.preset == "no_such_preset"
