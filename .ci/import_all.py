"""Import every module of the *installed* skinviewer and compare them with the checkout's modules:
a module missing from the wheel (a package setuptools did not find) fails here, and so does one that
does not import there. Run with the venv's python from outside the checkout:
    python import_all.py /path/to/checkout"""
from __future__ import annotations

import importlib
import importlib.util
import sys
import traceback
from pathlib import Path


def modules_of(root: Path) -> set[str]:
    out = set()
    for p in root.rglob("*.py"):
        if "__pycache__" in p.parts:
            continue
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out.add(".".join(parts))
    return out


def main() -> int:
    checkout = Path(sys.argv[1]).resolve()
    import skinviewer
    installed_root = Path(skinviewer.__file__).resolve().parent
    if checkout in installed_root.parents or installed_root == checkout / "skinviewer":
        print(f"import_all: skinviewer was imported from the checkout ({installed_root}), not the wheel")
        return 1
    wanted = modules_of(checkout / "skinviewer")
    have = modules_of(installed_root)
    failed = sorted(wanted - have)
    for name in failed:
        print(f"import_all: {name} is in the checkout but not in the installed package")
    for name in sorted(wanted & have):
        try:
            if name.endswith("__main__"):  # runs the command line when imported: find and compile it only
                spec = importlib.util.find_spec(name)
                assert spec and spec.origin, f"{name} not found"
                compile(Path(spec.origin).read_text(encoding="utf-8"), spec.origin, "exec")
            else:
                importlib.import_module(name)
        except Exception:
            failed.append(name)
            print(f"import_all: {name} does not import from the installed package:")
            traceback.print_exc(limit=3)
    for sub in ("shaders", "presets"):
        src = {p.relative_to(checkout / sub) for p in (checkout / sub).rglob("*") if p.is_file()}
        got = {p.relative_to(installed_root / sub) for p in (installed_root / sub).rglob("*") if p.is_file()}
        for p in sorted(src - got):
            failed.append(f"{sub}/{p}")
            print(f"import_all: {sub}/{p} is not in the installed package")
    print(f"import_all: {len(wanted & have)} modules imported from {installed_root}, "
          f"{len(failed)} missing or failing")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
