"""Writes the large-mesh benchmark scene (BENCHMARKS.md, "Meshes"): the BMW M6's
114 PLYs of bmw-m6.pbrt as they are (world space), every mesh diffuse with
albedo 0.5, a uniform sky of radiance 1, the pbrt file's camera, 1400x1000,
8 bounces, no Russian roulette. scripts/mitsuba_bmw.py renders the same.

    python3 scripts/make_bmw_scene.py GEOMETRY_DIR_AS_THE_SCENE_SEES_IT OUT.toml [PLY_DIR_HERE]
"""
import os
import sys

ref, out = sys.argv[1], sys.argv[2]
here = sys.argv[3] if len(sys.argv) > 3 else os.path.join(os.path.dirname(os.path.abspath(out)), ref)
plys = sorted(f for f in os.listdir(here) if f.endswith(".ply"))
with open(out, "w") as o:
    o.write("""# The large-mesh benchmark scene (BENCHMARKS.md, "Meshes"): the BMW M6 of
# pbrt-v4-scenes (CC0, tyrant monkey on Blend Swap), its 114 PLYs as they are,
# 0.79 M triangles, every mesh diffuse grey under a uniform sky. rlpt does not
# ship the model: put the scene's geometry/ folder at the path below, or run
# scripts/make_bmw_scene.py to point this file elsewhere.

[camera]
position = [-11.0, 0.8, 5.0]
look_at = [-2.0, -0.5, 0.0]
up = [0.0, 1.0, 0.0]
vfov = 30.0

[render]
width = 1400
height = 1000
spp = 64
max_bounces = 8

[environment]
radiance = [1.0, 1.0, 1.0]

[[material]]
name = "grey"
type = "diffuse"
albedo = [0.5, 0.5, 0.5]
""")
    for p in plys:
        o.write(f'\n[[mesh]]\nfile = "{ref}/{p}"\nmaterial = "grey"\n')
