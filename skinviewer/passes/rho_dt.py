"""The rho_dt energy-conservation table (seed 000 eq. 30-31) as a texture: rows = m, columns =
cos(theta) (skinviewer.physics.specular.rho_dt_table layout; sample with kelemen.glsl rho_dt_lookup).
Depends on specular.f0, specular.rho_s and the table size only: m is a texture coordinate."""
from __future__ import annotations

import numpy as np

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare

RHO_DT_RESOURCE = "rho_dt_lut"
RHO_DT_SIZE = (32, 32)  # (n_cos, n_m)


class RhoDtLutPass(Pass):
    name = "rho_dt_lut"
    uses_scene = False

    def __init__(self, size: tuple[int, int] = RHO_DT_SIZE):
        self.size = (int(size[0]), int(size[1]))

    def reflect(self, r: Reflection) -> None:
        declare(r.settings.specular.f0)
        declare(r.settings.specular.rho_s)
        r.output(RHO_DT_RESOURCE, TexSpec(self.size, 1, "f4", filter="linear"))

    def execute(self, ec) -> None:
        from skinviewer.physics.specular import rho_dt_table
        n_cos, n_m = self.size
        table = rho_dt_table(ec.settings.specular.f0, ec.settings.specular.rho_s, n_cos=n_cos, n_m=n_m)
        table = np.nan_to_num(np.clip(table, 0.0, 1.0), nan=1.0).astype(np.float32)
        ec.output(RHO_DT_RESOURCE).write(np.ascontiguousarray(table).tobytes())
