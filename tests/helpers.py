"""Reusable test helpers: small settings for a scene, and the all-textures-finite check every
technique's hard-case tests call."""
from __future__ import annotations

import numpy as np

from skinviewer.core.settings import Settings, with_values
from skinviewer.scene.scenes import scene_overrides


def small_settings(scene: str = "head", technique: str = "phong", size: int = 96, **assign) -> Settings:
    """Settings for a quick render: a built-in scene with its own lights/camera, small maps."""
    values = {"scene.name": scene, **scene_overrides(scene), "technique": technique,
              "render.width": size, "render.height": size, "scene.head_detail": 0,
              "shadow.map_size": 256, "gosselin.light_map_size": 256, "deon.irradiance_size": 256,
              "deon.tsm_size": 256}
    values.update(assign)
    return with_values(Settings(), values)


def assert_all_finite(renderer, settings: Settings, report=None) -> dict[str, np.ndarray]:
    """Render (unless a report is given) and check every texture the graph holds is finite.
    Returns the textures by name for further checks."""
    if report is None:
        report = renderer.render(settings)
    g = renderer.graph(settings.technique)
    out = {}
    bad = []
    for name in g.resources():
        arr = g.read(name)
        if not np.all(np.isfinite(arr)):
            n = int((~np.isfinite(arr)).sum())
            bad.append(f"{name}: {n} non-finite values")
        out[name] = arr
    assert not bad, "non-finite texels: " + "; ".join(bad)
    return out


def settings_fields():
    """(dotted path, field name, FieldInfo) of every editable settings field the panel draws: every
    section of the model (new techniques' included) and the first light."""
    from pydantic import BaseModel

    from skinviewer.core.settings import Settings
    from skinviewer.ui.widgets import classify
    out = []

    def walk(model, prefix):
        for name, f in type(model).model_fields.items():
            kind, _, _ = classify(f)
            if kind == "model":
                walk(getattr(model, name), f"{prefix}{name}.")
            elif kind != "other":
                out.append((f"{prefix}{name}", name, f))
    s = Settings()
    for sec, value in s:
        if isinstance(value, BaseModel):
            walk(value, sec + ".")
    walk(s.lights[0], "lights.0.")
    return out


def backlit_flap_column(renderer, s: Settings):
    """Render ``s`` (the backlit-ear scene, a screen-space technique) and read the lighting pass's
    diffuse down the image's centre column over the flap: (row indices, flap thickness in mm there,
    diffuse RGB there). The flap is 1.5 mm thick at y = 20 mm and 6 mm at y = -20 mm."""
    from skinviewer.passes.screen_space import DEPTH, DIFFUSE, focal_px
    renderer.render(s)
    E = renderer.read(s, DIFFUSE)
    dep = renderer.read(s, DEPTH)
    h = s.render.height
    f = focal_px(s.camera.fov_y, h)
    col = h // 2
    rows = [r for r in range(h) if dep[r, col, 3] > 0.5]
    ys = np.array([(r + 0.5 - h / 2) * dep[r, col, 0] / f for r in rows])  # world y (mm) at the centre column
    keep = np.abs(ys) < 17.0
    rows = np.array(rows)[keep]
    return rows, 1.5 + (20.0 - ys[keep]) / 40.0 * 4.5, E[rows, col, :3]
