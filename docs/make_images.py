"""Regenerate the README's gallery and the documentation's images under docs/images/, and the
bench table the docs quote (docs/data/). Not run in CI: on a software rasteriser it takes minutes.

    python docs/make_images.py                 # everything
    python docs/make_images.py --only gallery  # gallery | viewer | bench | sheet

Every image is made by the command line a user has (`python -m skinviewer ...`, printed as it
runs), so each picture in the docs names the command that made it. The shared head scan is read
from ../shared/assets/lee-perry-smith/ beside the checkout (or $SKINVIEWER_SCAN); without it its
images are skipped. The viewer's screenshot needs a display: the script starts it under xvfb-run
when there is none."""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
DATA = ROOT / "docs" / "data"
SCAN = Path(os.environ.get("SKINVIEWER_SCAN") or ROOT.parent / "shared/assets/lee-perry-smith/LeePerrySmith.glb")
SIZE = "360x360"
# the gallery: (file stem, technique); the default head and the scan, each under these three
TECHNIQUES = [("deon", "deon"), ("ssss", "ssss"), ("phong", "phong")]
BENCH_TECHNIQUES = "phong,gosselin,deon,ssss,separable,burley"
BENCH_SIZE = "160x160"


def skinviewer(*args: str, env: dict[str, str] | None = None) -> None:
    cmd = [sys.executable, "-m", "skinviewer", *args]
    print("$ skinviewer " + " ".join(args), flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True, env=env)


def shrink(png: Path, out: Path, width: int | None = None) -> None:
    """Copy a PNG into docs/images, optionally scaled to ``width``, as a small optimised PNG."""
    from PIL import Image
    im = Image.open(png).convert("RGB")
    if width and im.width > width:
        im = im.resize((width, round(im.height * width / im.width)), Image.Resampling.LANCZOS)
    out.parent.mkdir(parents=True, exist_ok=True)
    im.save(out, optimize=True)
    print(f"wrote {out.relative_to(ROOT)} ({out.stat().st_size // 1024} KiB)")


def gallery(tmp: Path) -> None:
    for stem, technique in TECHNIQUES:
        skinviewer("render", "--technique", technique, "--size", SIZE, "--out", str(tmp / f"head-{stem}.png"))
        shrink(tmp / f"head-{stem}.png", IMAGES / f"head-{stem}.png")
        if SCAN.is_file():
            skinviewer("render", "--mesh", str(SCAN), "--set", "scene.mm_per_unit=48", "--technique", technique,
                       "--size", SIZE, "--out", str(tmp / f"scan-{stem}.png"))
            shrink(tmp / f"scan-{stem}.png", IMAGES / f"scan-{stem}.png")
        else:
            print(f"no scan at {SCAN}: scan-{stem}.png not made")


VIEWER_SNIPPET = """
import sys
from skinviewer.ground.settings import Settings
from skinviewer.ui.app import create_app, destroy_app
app = create_app(Settings(), size=(1280, 800), vsync=False)
try:
    for _ in range(6):
        app.step()
    app.frame.request_screenshot(sys.argv[1], include_ui=True)
    for _ in range(2):
        app.step()
finally:
    destroy_app(app)
"""


def viewer(tmp: Path) -> None:
    """The viewer's window as a user first sees it (default head, default technique, panel open)."""
    shot = tmp / "viewer.png"
    cmd = [sys.executable, "-c", VIEWER_SNIPPET, str(shot)]
    if not os.environ.get("DISPLAY"):
        cmd = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24"] + cmd
    print("$ (xvfb-run) the viewer at 1280x800, 6 frames, screenshot with the UI", flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)
    shrink(shot, IMAGES / "viewer.png", width=960)


def bench(tmp: Path) -> None:
    out = tmp / "bench"
    skinviewer("bench", "--scene", "head", "--quick", "--size", BENCH_SIZE, "--techniques", BENCH_TECHNIQUES,
               "--out", str(out))
    shrink(out / "pareto.png", IMAGES / "pareto.png", width=720)
    heat = sorted((out / "heatmaps").glob("*.png"))
    pick = next((p for p in heat if "deon" in p.name), heat[0] if heat else None)
    if pick is not None:  # a small map: shown at twice its size, pixels kept sharp
        from PIL import Image
        im = Image.open(pick).convert("RGB")
        im.resize((im.width * 2, im.height * 2), Image.Resampling.NEAREST).save(IMAGES / "heatmap.png", optimize=True)
        print(f"wrote docs/images/heatmap.png from {pick.name}")
    DATA.mkdir(parents=True, exist_ok=True)
    # included inside a page (docs/user/bench.md): its title one level down
    text = (out / "results.md").read_text(encoding="utf-8")
    (DATA / "bench_head_quick.md").write_text(text.replace("# ", "### ", 1), encoding="utf-8")
    print(f"wrote {(DATA / 'bench_head_quick.md').relative_to(ROOT)} "
          f"(skinviewer bench --scene head --quick --size {BENCH_SIZE} --techniques {BENCH_TECHNIQUES})")


def sheet(tmp: Path) -> None:
    """docs/exchange.md's contact sheet (techniques x views, labelled)."""
    skinviewer("sheet", "--techniques", "deon,burley2,ssss", "--views", "front,34,back", "--size", "192x192",
               "--no-truth", "--out", str(tmp / "sheet.png"))
    shrink(tmp / "sheet.png", IMAGES / "sheet.png")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parts = {"gallery": gallery, "viewer": viewer, "bench": bench, "sheet": sheet}
    ap.add_argument("--only", choices=list(parts), action="append")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        for name in a.only or list(parts):
            parts[name](Path(d))
    return 0


if __name__ == "__main__":
    sys.exit(main())
