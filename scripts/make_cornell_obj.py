"""Writes scenes/meshes/cornell-box.obj and .mtl: the Cornell box from the
measurements Cornell's Program of Computer Graphics publishes ("Cornell Box
Data", https://www.graphics.cornell.edu/online/box/data.html), in millimetres,
one quad per face, the lamp a quad of its own that the MTL makes emit (Ke).
Colours are the usual RGB stand-ins for the measured spectra.

    python3 scripts/make_cornell_obj.py
"""
import os

faces = {
    "light": [[(343.0, 548.8, 227.0), (343.0, 548.8, 332.0), (213.0, 548.8, 332.0), (213.0, 548.8, 227.0)]],
    "white": [
        # floor, ceiling, back wall
        [(552.8, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 559.2), (549.6, 0.0, 559.2)],
        [(556.0, 548.8, 0.0), (556.0, 548.8, 559.2), (0.0, 548.8, 559.2), (0.0, 548.8, 0.0)],
        [(549.6, 0.0, 559.2), (0.0, 0.0, 559.2), (0.0, 548.8, 559.2), (556.0, 548.8, 559.2)],
        # short block
        [(130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0), (290.0, 165.0, 114.0)],
        [(290.0, 0.0, 114.0), (290.0, 165.0, 114.0), (240.0, 165.0, 272.0), (240.0, 0.0, 272.0)],
        [(130.0, 0.0, 65.0), (130.0, 165.0, 65.0), (290.0, 165.0, 114.0), (290.0, 0.0, 114.0)],
        [(82.0, 0.0, 225.0), (82.0, 165.0, 225.0), (130.0, 165.0, 65.0), (130.0, 0.0, 65.0)],
        [(240.0, 0.0, 272.0), (240.0, 165.0, 272.0), (82.0, 165.0, 225.0), (82.0, 0.0, 225.0)],
        # tall block
        [(423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0), (472.0, 330.0, 406.0)],
        [(423.0, 0.0, 247.0), (423.0, 330.0, 247.0), (472.0, 330.0, 406.0), (472.0, 0.0, 406.0)],
        [(472.0, 0.0, 406.0), (472.0, 330.0, 406.0), (314.0, 330.0, 456.0), (314.0, 0.0, 456.0)],
        [(314.0, 0.0, 456.0), (314.0, 330.0, 456.0), (265.0, 330.0, 296.0), (265.0, 0.0, 296.0)],
        [(265.0, 0.0, 296.0), (265.0, 330.0, 296.0), (423.0, 330.0, 247.0), (423.0, 0.0, 247.0)],
    ],
    "red": [[(552.8, 0.0, 0.0), (549.6, 0.0, 559.2), (556.0, 548.8, 559.2), (556.0, 548.8, 0.0)]],
    "green": [[(0.0, 0.0, 559.2), (0.0, 0.0, 0.0), (0.0, 548.8, 0.0), (0.0, 548.8, 559.2)]],
}
materials = {
    "white": "Kd 0.73 0.73 0.73",
    "red": "Kd 0.65 0.05 0.05",
    "green": "Kd 0.12 0.45 0.15",
    "light": "Kd 0.78 0.78 0.78\nKe 17 12 4",
}
here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "meshes")
os.makedirs(here, exist_ok=True)
with open(os.path.join(here, "cornell-box.mtl"), "w") as m:
    m.write("# Written by scripts/make_cornell_obj.py\n")
    for name, body in materials.items():
        m.write(f"\nnewmtl {name}\n{body}\n")
with open(os.path.join(here, "cornell-box.obj"), "w") as o:
    o.write("# The Cornell box from Cornell's published measurements (mm); written by\n")
    o.write("# scripts/make_cornell_obj.py\nmtllib cornell-box.mtl\n")
    n = 0
    for name, quads in faces.items():
        o.write(f"\no {name}\nusemtl {name}\n")
        for q in quads:
            for v in q:
                o.write("v %g %g %g\n" % v)
            o.write("f %d %d %d %d\n" % (n + 1, n + 2, n + 3, n + 4))
            n += 4
