"""Package discovery, the one thing pyproject.toml cannot say: the Python packages are found under
skinviewer/ (``find_namespace_packages``: ground/, kernel/, engine/, physics/ and scene/ have no ``__init__.py``), and
the GLSL and presets, which live at the top of the checkout so they can be edited live, are found
recursively under shaders/ and presets/ (``find_namespace_packages``) and shipped as ``skinviewer.shaders`` / ``skinviewer.presets``
(the mapping is ``[tool.setuptools.package-dir]`` in pyproject.toml). Everything else is there."""
from setuptools import find_namespace_packages, setup


def _data_packages(folder: str) -> list[str]:
    name = f"skinviewer.{folder}"
    return [name] + [f"{name}.{sub}" for sub in find_namespace_packages(where=folder, exclude=_NOT_PACKAGES)]


_NOT_PACKAGES = ["__pycache__", "*.__pycache__"]
setup(packages=find_namespace_packages(include=["skinviewer", "skinviewer.*"], exclude=_NOT_PACKAGES)
      + _data_packages("shaders") + _data_packages("presets"))
