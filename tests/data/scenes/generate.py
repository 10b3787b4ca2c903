#!/usr/bin/env python3
"""Writes the scene files of this directory (wandsculpt-document v1 JSON).

Run from anywhere: `python3 tests/data/scenes/generate.py`. Deterministic: the same
files every time. Wand samples are 90 Hz positions near the surface with a small
tremor, as the wand would give them; sculpt-core projects them onto the target.
"""
import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
S2 = math.sqrt(0.5)


def clamped(count, degree):
    inner = count - degree - 1
    return [0.0] * (degree + 1) + [(k + 1) / (inner + 1) for k in range(inner)] + [1.0] * (degree + 1)


def grid_surface(nu, nv, degree, point):
    """A clamped B-spline surface whose control points are point(i/(nu-1), j/(nv-1))."""
    cps = [[list(point(i / (nu - 1), j / (nv - 1))) for j in range(nv)] for i in range(nu)]
    return {"degree_u": degree, "degree_v": degree, "knots_u": clamped(nu, degree),
            "knots_v": clamped(nv, degree), "control_points": cps}


def tremor(k):
    return 0.0003 * math.sin(k * 1.7), 0.0003 * math.cos(k * 2.3), 0.0002 * math.sin(k * 0.9)


def samples(path, n):
    out = []
    for k in range(n):
        x, y, z = path(k / (n - 1))
        dx, dy, dz = tremor(k)
        out.append([round(k / 90.0, 6), x + dx, y + dy, z + dz])
    return out


def tool(profile, width, depth, mode, taper):
    return {"profile": profile, "width": width, "depth": depth, "mode": mode, "taper": taper}


def document(description, surface, name, strokes):
    doc = {"format": "wandsculpt-document", "version": 1, "description": description,
           "targets": [{"id": 1, "name": name, "surface": surface}], "strokes": []}
    for k, (t, path, n) in enumerate(strokes):
        doc["strokes"].append({"id": k + 2, "target": 1, "tool": t, "samples": samples(path, n)})
    return doc


def write(name, doc):
    with open(os.path.join(HERE, name), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


# 1, 2: a gently curved bicubic patch, 1 m x 0.8 m, bulging 6 cm in the middle.
def patch_height(x, y):
    return 0.06 * math.sin(math.pi * x) * math.sin(math.pi * y / 0.8)


patch = grid_surface(6, 6, 3, lambda u, v: (u, 0.8 * v, patch_height(u, 0.8 * v)))


def across(y):
    return lambda s: (0.15 + 0.7 * s, y, patch_height(0.15 + 0.7 * s, y) + 0.002)


carve = tool("v", 0.05, 0.012, "carve", 0.05)
write("curved-patch-carved.json", document(
    "Paper example 1 (Figs. 18-19): a gently curved patch with 3 parallel carved V strokes.",
    patch, "curved patch", [(carve, across(y), 120) for y in (0.25, 0.4, 0.55)]))
emboss = tool("u", 0.05, 0.01, "emboss", 0.05)
write("curved-patch-embossed.json", document(
    "Paper example 2 (Figs. 20-21): the same patch with 3 parallel embossed U strokes.",
    patch, "curved patch", [(emboss, across(y), 120) for y in (0.25, 0.4, 0.55)]))

# 3: an exact NURBS sphere (radius 0.3 m), two carved strokes crossing three times.
R = 0.3
circle = [(1, 0, 1), (1, 1, S2), (0, 1, 1), (-1, 1, S2), (-1, 0, 1), (-1, -1, S2), (0, -1, 1), (1, -1, S2), (1, 0, 1)]
profile = [(0, -1, 1), (1, -1, S2), (1, 0, 1), (1, 1, S2), (0, 1, 1)]
sphere = {
    "degree_u": 2, "degree_v": 2,
    "knots_u": [0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1],
    "knots_v": [0, 0, 0, 0.5, 0.5, 1, 1, 1],
    "control_points": [[[R * cx * px, R * cy * px, R * pz] for (px, pz, _) in profile] for (cx, cy, _) in circle],
    "weights": [[cw * pw for (_, _, pw) in profile] for (_, _, cw) in circle],
}


def on_sphere(lon_deg, lat_deg, lift=0.002):
    lon, lat = math.radians(lon_deg), math.radians(lat_deg)
    r = R + lift
    return (r * math.cos(lat) * math.cos(lon), r * math.cos(lat) * math.sin(lon), r * math.sin(lat))


equator = lambda s: on_sphere(40 + 250 * s, 0.0)
# Crosses the equator at longitudes 100, 160 and 220 degrees.
wave = lambda s: on_sphere(75 + 170 * s, 20 * math.sin(math.radians(3 * (75 + 170 * s - 100))))
sph_tool = tool("v", 0.04, 0.01, "carve", 0.03)
deep = tool("u", 0.04, 0.014, "carve", 0.03)
write("sphere-overlaps.json", document(
    "Paper example 3 (Figs. 22-23): a NURBS sphere with 2 carved strokes crossing in 3 places.",
    sphere, "sphere", [(sph_tool, equator, 200), (deep, wave, 200)]))


# 4: a mask-like face (Hahoe mask, paper example 4), about 0.22 m x 0.28 m.
def face_height(x, y):
    dome = 0.06 * max(0.0, 1 - (x / 0.13) ** 2 - (y / 0.16) ** 2) ** 0.5
    nose = 0.025 * math.exp(-((x / 0.018) ** 2) - ((y + 0.01) / 0.05) ** 2)
    eyes = -0.012 * (math.exp(-(((x - 0.045) / 0.022) ** 2) - ((y - 0.03) / 0.015) ** 2)
                     + math.exp(-(((x + 0.045) / 0.022) ** 2) - ((y - 0.03) / 0.015) ** 2))
    cheeks = 0.008 * (math.exp(-(((x - 0.06) / 0.03) ** 2) - ((y + 0.04) / 0.03) ** 2)
                      + math.exp(-(((x + 0.06) / 0.03) ** 2) - ((y + 0.04) / 0.03) ** 2))
    return dome + nose + eyes + cheeks


face = grid_surface(14, 16, 3, lambda u, v: (-0.11 + 0.22 * u, -0.14 + 0.28 * v,
                                               face_height(-0.11 + 0.22 * u, -0.14 + 0.28 * v)))


def on_face(fx, fy):
    return lambda s: (fx(s), fy(s), face_height(fx(s), fy(s)) + 0.001)


wrinkle = tool("u", 0.006, 0.0025, "emboss", 0.01)
brow = tool("v", 0.01, 0.004, "carve", 0.012)
cut = tool("v", 0.007, 0.003, "carve", 0.008)
write("mask-face.json", document(
    "Paper example 4 (Figs. 24-25): a mask-like face with embossed wrinkles (a, b, d, e), a carved "
    "eyebrow (c) and two crossing carved strokes (f).",
    face, "mask face", [
        (wrinkle, on_face(lambda s: -0.06 + 0.12 * s, lambda s: 0.085 + 0.012 * math.sin(math.pi * s)), 90),
        (wrinkle, on_face(lambda s: -0.05 + 0.10 * s, lambda s: 0.105 + 0.010 * math.sin(math.pi * s)), 90),
        (brow, on_face(lambda s: 0.015 + 0.06 * s, lambda s: 0.05 + 0.012 * math.sin(math.pi * s)), 80),
        (wrinkle, on_face(lambda s: -0.035 - 0.02 * s, lambda s: -0.03 - 0.05 * s), 70),
        (wrinkle, on_face(lambda s: 0.035 + 0.02 * s, lambda s: -0.03 - 0.05 * s), 70),
        (cut, on_face(lambda s: -0.09 + 0.05 * s, lambda s: -0.02 - 0.05 * s), 70),
        (cut, on_face(lambda s: -0.09 + 0.05 * s, lambda s: -0.07 + 0.05 * s), 70),
    ]))


# 5: a saddle z = 0.3 (x^2 - y^2) over 1 m x 1 m (exact as a biquadratic).
def saddle_point(u, v):
    bx = [0.25, -0.25, 0.25]
    i, j = round(2 * u), round(2 * v)
    return (u - 0.5, v - 0.5, 0.3 * (bx[i] - bx[j]))


saddle = grid_surface(3, 3, 2, saddle_point)
sz = lambda x, y: 0.3 * (x * x - y * y) + 0.002
write("saddle.json", document(
    "A saddle with a carved diagonal V groove and an embossed U ridge crossing it.",
    saddle, "saddle", [
        (tool("v", 0.05, 0.015, "carve", 0.04), lambda s: (-0.35 + 0.7 * s, -0.35 + 0.7 * s, sz(-0.35 + 0.7 * s, -0.35 + 0.7 * s)), 120),
        (tool("u", 0.04, 0.01, "emboss", 0.04), lambda s: (0.3 - 0.6 * s, -0.3 + 0.6 * s, sz(0.3 - 0.6 * s, -0.3 + 0.6 * s)), 110),
    ]))


# 6: a wavy surface over 1 m x 1 m, with two crossing carved strokes and a ridge.
def wavy_height(x, y):
    return 0.04 * math.sin(3 * math.pi * x) * math.cos(2 * math.pi * y)


wavy = grid_surface(12, 12, 3, lambda u, v: (u, v, wavy_height(u, v)))
wz = lambda x, y: (x, y, wavy_height(x, y) + 0.002)
write("wavy.json", document(
    "A wavy surface with two crossing carved grooves and an embossed ridge.",
    wavy, "wavy", [
        (tool("v", 0.05, 0.012, "carve", 0.04), lambda s: wz(0.15 + 0.7 * s, 0.3 + 0.4 * s), 150),
        (tool("u", 0.05, 0.016, "carve", 0.04), lambda s: wz(0.15 + 0.7 * s, 0.7 - 0.4 * s), 150),
        (tool("u", 0.04, 0.01, "emboss", 0.03), lambda s: wz(0.5 + 0.3 * math.cos(math.pi * s), 0.15 + 0.1 * math.sin(math.pi * s)), 100),
    ]))
