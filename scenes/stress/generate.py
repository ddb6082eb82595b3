#!/usr/bin/env python3
"""Writes the OBJ/MTL files of the stress scenes glossy/, slit/ and caustic/ (corner/ was
written by hand). Run from this folder: python3 generate.py. The output is committed; this
script documents the geometry exactly and regenerates it bit for bit.

Every quad is given counter-clockwise as seen from the side it faces (its front), so that
the geometric normal (b - a) x (c - a) points into the room."""
import math
import os


class Obj:
    def __init__(self, header):
        self.lines = [f"# {line}" for line in header.splitlines()]
        self.header = len(self.lines)
        self.nv = 0
        self.nn = 0

    def quad(self, name, material, corners):
        self.lines.append(f"\n# {name}\nusemtl {material}")
        for p in corners:
            self.lines.append("v " + " ".join(f"{c:.6g}" for c in p))
        b = self.nv
        self.lines.append(f"f {b + 1} {b + 2} {b + 3} {b + 4}")
        self.nv += 4

    def box(self, name, material, lo, hi):
        """An axis-aligned box, faces outwards (bottom face omitted: it rests on the floor)."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        self.quad(f"{name} top", material, [(x0, y1, z1), (x1, y1, z1), (x1, y1, z0), (x0, y1, z0)])
        self.quad(f"{name} front", material, [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)])
        self.quad(f"{name} back", material, [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)])
        self.quad(f"{name} left", material, [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)])
        self.quad(f"{name} right", material, [(x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1)])

    def sphere(self, name, material, centre, radius, rings=24, segments=48):
        """A UV sphere with vertex normals (smooth shading normals)."""
        self.lines.append(f"\n# {name}: centre {centre}, radius {radius}\nusemtl {material}")
        cx, cy, cz = centre
        index = {}
        for i in range(rings + 1):
            th = math.pi * i / rings
            for j in range(segments):
                if i in (0, rings) and j > 0:
                    continue
                ph = 2 * math.pi * j / segments
                n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
                self.lines.append("v " + " ".join(f"{c + radius * d:.6g}" for c, d in zip(centre, n)))
                self.lines.append("vn " + " ".join(f"{d:.6g}" for d in n))
                self.nv += 1
                self.nn += 1
                index[(i, j)] = (self.nv, self.nn)

        def v(i, j):
            return index[(i, 0)] if i in (0, rings) else index[(i, j % segments)]

        for i in range(rings):
            for j in range(segments):
                a, b, c, d = v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i + 1, j)
                # Outward facing: counter-clockwise seen from outside.
                tri = [(a, b, c), (a, c, d)]
                for t in tri:
                    if len(set(t)) == 3:
                        self.lines.append("f " + " ".join(f"{k[0]}//{k[1]}" for k in t))

    def write(self, folder, name, materials):
        """Writes folder/name.obj and its MTL, folder/name.mtl, of the given text."""
        self.lines.insert(self.header, f"mtllib {name}.mtl")
        with open(f"{folder}/{name}.obj", "w") as f:
            f.write("\n".join(self.lines) + "\n")
        with open(f"{folder}/{name}.mtl", "w") as f:
            f.write(materials)


def room(o, x=(-1.0, 1.0), y=(0.0, 1.0), z=(-1.0, 1.0), walls=("floor", "back", "left", "right"),
         materials=None):
    (x0, x1), (y0, y1), (z0, z1) = x, y, z
    m = materials or {}
    faces = {
        "floor": [(x0, y0, z1), (x1, y0, z1), (x1, y0, z0), (x0, y0, z0)],
        "ceiling": [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
        "back": [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        "front": [(x1, y0, z1), (x0, y0, z1), (x0, y1, z1), (x1, y1, z1)],
        "left": [(x0, y0, z1), (x0, y0, z0), (x0, y1, z0), (x0, y1, z1)],
        "right": [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)],
    }
    for w in walls:
        o.quad(f"{w} (facing into the room)", m.get(w, "wall"), faces[w])


def glossy():
    o = Obj("Glossy stress scene (pir's own; public domain): a near-mirror GGX floor in front of\n"
            "a diffuse back wall lit at close range; see README.md.")
    room(o, y=(0.0, 1.3), materials={"floor": "floor", "left": "red", "right": "green"})
    # The light faces the back wall (-z), above the camera's view.
    o.quad("light, facing -z", "light", [(0.2, 0.95, 0.8), (-0.2, 0.95, 0.8), (-0.2, 1.25, 0.8), (0.2, 1.25, 0.8)])
    o.box("block", "wall", (0.25, 0.0, -0.75), (0.55, 0.3, -0.45))
    o.write("glossy", "glossy", "# Materials of the glossy stress scene (the scene file sets the floor).\n"
            "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl wall\nKd 0.75 0.75 0.75\n"
            "newmtl red\nKd 0.7 0.15 0.1\nnewmtl green\nKd 0.15 0.6 0.15\n"
            "newmtl light\nKd 0 0 0\nKe 12 12 12\n")


def slit():
    o = Obj("Slit stress scene (pir's own; public domain): a closed room lit only through a 3 cm slit\n"
            "in its ceiling by a light above it; see README.md.")
    room(o, walls=("floor", "back", "front", "left", "right"),
         materials={"left": "red", "right": "green"})
    w = 0.015
    o.quad("ceiling, left of the slit, facing -y", "wall", [(-1, 1, -1), (-w, 1, -1), (-w, 1, 1), (-1, 1, 1)])
    o.quad("ceiling, right of the slit, facing -y", "wall", [(w, 1, -1), (1, 1, -1), (1, 1, 1), (w, 1, 1)])
    # 40 cm above the slit, so that the light comes through it as a narrow sheet.
    o.quad("light above the slit, facing -y", "light",
           [(-0.15, 1.4, -0.6), (0.15, 1.4, -0.6), (0.15, 1.4, 0.6), (-0.15, 1.4, 0.6)])
    o.box("block", "block", (-0.55, 0.0, -0.45), (-0.25, 0.45, -0.15))
    o.write("slit", "slit", "# Materials of the slit stress scene.\n"
            "newmtl wall\nKd 0.75 0.75 0.75\nnewmtl red\nKd 0.7 0.15 0.1\nnewmtl green\nKd 0.15 0.6 0.15\n"
            "newmtl block\nKd 0.6 0.55 0.45\nnewmtl light\nKd 0 0 0\nKe 40 40 40\n")


def caustic():
    o = Obj("Caustic stress scene (pir's own; public domain): a glass sphere and a mirror wall under a\n"
            "small light; see README.md.")
    room(o, y=(0.0, 1.3), walls=("floor", "ceiling", "back", "left", "right"),
         materials={"left": "red", "right": "mirror"})
    o.quad("light, facing -y", "light",
           [(-0.05, 1.29, -0.15), (0.05, 1.29, -0.15), (0.05, 1.29, -0.05), (-0.05, 1.29, -0.05)])
    o.sphere("glass sphere", "glass", (-0.25, 0.3, -0.1), 0.28)
    o.write("caustic", "caustic", "# Materials of the caustic stress scene.\n"
            "newmtl wall\nKd 0.75 0.75 0.75\nnewmtl red\nKd 0.7 0.15 0.1\n"
            "newmtl mirror\nKs 0.9 0.9 0.9\nillum 5\nnewmtl glass\nNi 1.5\nillum 7\n"
            "newmtl light\nKd 0 0 0\nKe 300 300 300\n")


if __name__ == "__main__":
    os.chdir(os.path.dirname(os.path.abspath(__file__)))
    glossy()
    slit()
    caustic()
