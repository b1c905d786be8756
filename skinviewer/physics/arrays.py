"""The numerics' array types, for mypy's strict mode on ``ground/``, ``kernel/``, ``engine/`` and ``physics/``: an array's dtype is
part of its type, so arithmetic on float64 arrays stays typed instead of falling back to ``Any``."""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]  # the numerics' working precision (profiles, truth, fits)
Float32Array = NDArray[np.float32]  # what textures upload and read back
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
AnyArray = NDArray[Any]  # an array whose dtype the caller chooses (images of any depth, passed through)
IndexArray = NDArray[np.integer[Any]]  # triangle indices, texel coordinates (any integer width)
