"""Embree's closest-hit rate on the rays `cargo bench --bench trace` traces: the reference
the tracer ratios of docs/performance.md are measured against (one thread, closest hit).

    WARPFIT_DUMP_RAYS=/tmp/rays cargo bench --bench trace -- rays/atrium
    python3 -m venv /tmp/embree && /tmp/embree/bin/pip install numpy embreex
    /tmp/embree/bin/python benches/embree_reference.py /tmp/rays/atrium 5
    /tmp/embree/bin/python benches/embree_reference.py /tmp/rays/atrium 5 robust

With `occluded` among the further arguments the rays are occlusion queries, each to its
reach in CASE.tmax.f32 (the shadow streams `WARPFIT_DUMP_STREAMS` writes).
The optional argument `robust` builds the scene with RTC_SCENE_FLAG_ROBUST: Embree's
watertight triangle test, the guarantee warpfit's tracer always gives (its default test
lets a ray slip through a shared edge). Reads CASE.tris.f32 (float32 LE: triangles × 3 vertices × xyz, world units) and
CASE.rays.f32 (float32 LE: rays × origin xyz, unit direction xyz); prints one line per round
with Mrays/s. Compare only with a warpfit figure measured in the same sitting."""
import sys
import time

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

case, rounds = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 5
robust = "robust" in sys.argv[3:]
# occlusion queries instead, each ray to its reach in CASE.tmax.f32 (the dumped shadow
# streams, `warpfit`'s WARPFIT_DUMP_STREAMS)
occluded = "occluded" in sys.argv[3:]
triangles = np.fromfile(case + ".tris.f32", dtype="<f4").reshape(-1, 3, 3)
rays = np.fromfile(case + ".rays.f32", dtype="<f4").reshape(-1, 6)
origins = np.ascontiguousarray(rays[:, :3])
directions = np.ascontiguousarray(rays[:, 3:])
scene = rtcore_scene.EmbreeScene(robust=robust)
TriangleMesh(scene, triangles)
dists = np.fromfile(case + ".tmax.f32", dtype="<f4") if occluded else None
query = "OCCLUDED" if occluded else "INTERSECT"
start = time.perf_counter()
scene.run(origins[:1], directions[:1])  # Embree builds its BVH on the first query
print(f"{case}: {len(triangles)} triangles, {len(rays)} rays, {'robust' if robust else 'default'} triangle test, BVH build {time.perf_counter() - start:.3f} s")
best = float("inf")
for r in range(rounds):
    start = time.perf_counter()
    if occluded:
        hits = int((scene.run(origins, directions, dists=dists, query=query) != -1).sum())
    else:
        hits = int((scene.run(origins, directions) != -1).sum())
    seconds = time.perf_counter() - start
    best = min(best, seconds)
    print(f"round {r}: {len(rays) / seconds / 1e6:.2f} Mrays/s closest hit, 1 thread ({hits} hits)")
print(f"best of {rounds} passes {len(rays) / best / 1e6:.2f} Mrays/s {'occlusion' if occluded else 'closest hit'}, 1 thread")
