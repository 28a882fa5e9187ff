#!/usr/bin/env python3
"""Writes scenes/cornell-box.obj and .mtl: the classic Cornell box in a 2 x 2 x 2
frame (floor y = 0, ceiling y = 2, back wall z = -1, red wall x = -1, green wall
x = +1), two boxes, and a ceiling area light facing down; and
scenes/cornell-empty.obj: the same room and light without the boxes (for
scenes that put their own objects in it, such as cornell-spheres.toml).

Albedos and light radiance are the values of the widely used RGB Cornell box
(Bitterli's rendering resources and Mitsuba 3's cbox scene). Every quad winds
counter-clockwise seen from its front (the side facing into the room).
"""
import math
import os

here = os.path.dirname(os.path.abspath(__file__))
verts, faces = [], []


def quad(a, b, c, d, mat):
    """Quad a-b-c-d, counter-clockwise seen from the front."""
    base = len(verts) + 1
    verts.extend([a, b, c, d])
    faces.append((mat, (base, base + 1, base + 2)))
    faces.append((mat, (base, base + 2, base + 3)))


def box(cx, cz, sx, sy, sz, angle_deg, mat):
    """An axis-aligned box rotated about y, outward-facing, without its bottom."""
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)

    def p(x, y, z):
        x, z = x * sx / 2, z * sz / 2
        return (cx + c * x + s * z, y * sy, cz - s * x + c * z)

    quad(p(-1, 1, 1), p(1, 1, 1), p(1, 1, -1), p(-1, 1, -1), mat)  # top (+y)
    quad(p(-1, 0, 1), p(1, 0, 1), p(1, 1, 1), p(-1, 1, 1), mat)  # front (+z)
    quad(p(1, 0, -1), p(-1, 0, -1), p(-1, 1, -1), p(1, 1, -1), mat)  # back (-z)
    quad(p(1, 0, 1), p(1, 0, -1), p(1, 1, -1), p(1, 1, 1), mat)  # right (+x)
    quad(p(-1, 0, -1), p(-1, 0, 1), p(-1, 1, 1), p(-1, 1, -1), mat)  # left (-x)


# room: fronts face the inside
quad((-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1), "white")  # floor, up
quad((-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1), "white")  # ceiling, down
quad((-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1), "white")  # back wall, +z
quad((-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1), "red")  # left wall, +x
quad((1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1), "green")  # right wall, -x
# light: 0.47 x 0.38, just below the ceiling, facing down
lx, lz, ly = 0.235, 0.19, 1.99
quad((-lx, ly, -lz), (lx, ly, -lz), (lx, ly, lz), (-lx, ly, lz), "light")
room = (len(verts), len(faces))
box(0.33, 0.37, 0.6, 0.6, 0.6, -17.0, "white")  # short box
box(-0.34, -0.28, 0.6, 1.2, 0.6, 17.0, "white")  # tall box



def write_obj(name, title, verts, faces):
    with open(os.path.join(here, name), "w") as f:
        f.write("# %s, written by scenes/make_cornell_box.py\n" % title)
        f.write("mtllib cornell-box.mtl\n")
        for v in verts:
            f.write("v %.6f %.6f %.6f\n" % v)
        current = None
        for mat, (a, b, c) in faces:
            if mat != current:
                f.write("usemtl %s\n" % mat)
                current = mat
            f.write("f %d %d %d\n" % (a, b, c))


write_obj("cornell-box.obj", "The Cornell box", verts, faces)
write_obj(
    "cornell-empty.obj",
    "The Cornell box without its boxes",
    verts[: room[0]],
    faces[: room[1]],
)

with open(os.path.join(here, "cornell-box.mtl"), "w") as f:
    f.write("# Cornell box materials (RGB values of the common cbox scene)\n")
    for name, kd, ke in [
        ("white", (0.725, 0.71, 0.68), None),
        ("red", (0.63, 0.065, 0.05), None),
        ("green", (0.14, 0.45, 0.091), None),
        ("light", (0.78, 0.78, 0.78), (17.0, 12.0, 4.0)),
    ]:
        f.write("\nnewmtl %s\nKd %.3f %.3f %.3f\n" % ((name,) + kd))
        if ke:
            f.write("Ke %.3f %.3f %.3f\n" % ke)
