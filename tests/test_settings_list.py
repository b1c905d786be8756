"""`skinviewer settings --list`: every settable key, generated from the model, and each one really
settable with --set (the list and the model cannot drift apart)."""
import json
import subprocess
import sys

from skinviewer.cli.settings_list import rows
from skinviewer.ground.settings import Settings, get_path, parse_assignments, with_values


def test_every_listed_key_is_settable_with_its_default():
    table = rows()
    keys = [r["key"] for r in table]
    assert "lights.0.direction" in keys and "deon.gaussians.5.variance" in keys and "render.exposure" in keys
    s = Settings()
    for r in table:
        if isinstance(r["default"], dict) or r["key"] == "schema_version":
            continue
        text = json.dumps(r["default"]) if not isinstance(r["default"], str) else r["default"]
        s2 = with_values(s, parse_assignments([f"{r['key']}={text}"]))
        assert get_path(s2, r["key"]) == get_path(s, r["key"]), r["key"]


def test_units_and_ranges_are_listed():
    by_key = {r["key"]: r for r in rows()}
    assert by_key["shadow.pcf"]["unit"] == "texels" and ">=0" in by_key["shadow.pcf"]["range"]
    assert by_key["camera.fov_y"]["unit"] == "deg"


def test_cli_prints_conventions_and_json():
    p = subprocess.run([sys.executable, "-m", "skinviewer", "settings", "--list"], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0 and "TOWARDS the light" in p.stdout and "deon.mix" in p.stdout
    pj = subprocess.run([sys.executable, "-m", "skinviewer", "settings", "--json"], capture_output=True, text=True,
                        timeout=60)
    assert pj.returncode == 0 and any(r["key"] == "deon.mix" for r in json.loads(pj.stdout))
