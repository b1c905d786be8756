import time, numpy as np
from skinviewer.core.settings import load_preset, with_values
from skinviewer.core import reference as R
s = load_preset("presets/studio-environment.json")
s = with_values(s, {"render.width": 64, "render.height": 64, "scene.head_detail": 1})
t = time.perf_counter()
ref = R.compute_reference(s, use_cache=False)
print(time.perf_counter() - t, ref.meta["env"], ref.meta["seconds"])
np.save("/tmp/ref64a.npy", ref.lit)
