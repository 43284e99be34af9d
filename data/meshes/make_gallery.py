#!/usr/bin/env python3
"""Writes gallery.gltf and gallery_floor.png: a small level as a DCC tool exports it, for
`warpfit init` and the loader's tests. Solid boxes (walls, roof slabs, floor, pillars, a
plinth) with doubleSided materials (Blender's default), a base-colour texture on the floor,
a window in the +x wall and a skylight, and KHR_lights_punctual point and spot lights.
Units: metres, +Y up (glTF's convention). Run: python3 make_gallery.py (deterministic)."""
import base64, json, math, struct, zlib

def png(path, w, h, pixel):
    raw = b"".join(b"\x00" + bytes(c for x in range(w) for c in pixel(x, y)) for y in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    open(path, "wb").write(data)

def box(lo, hi, uv_scale=1.0):
    """24 vertices (4 per face, outward winding), 36 indices, planar UVs per face."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    faces = [  # (corners counter-clockwise seen from outside)
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],  # +x
        [(x0, y0, z1), (x0, y1, z1), (x0, y1, z0), (x0, y0, z0)],  # -x
        [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)],  # +y
        [(x0, y0, z1), (x0, y0, z0), (x1, y0, z0), (x1, y0, z1)],  # -y
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],  # +z
        [(x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0)],  # -z
    ]
    pos, uv, idx = [], [], []
    for f in faces:
        b = len(pos)
        for (x, y, z) in f:
            pos.append((x, y, z))
            # planar projection on the face's two other axes
            uv.append(((x + z) * uv_scale, (y + z if abs(f[0][1] - f[2][1]) > 0 else x) * uv_scale))
        idx += [b, b + 1, b + 2, b, b + 2, b + 3]
    return pos, uv, idx

def merge(boxes):
    pos, uv, idx = [], [], []
    for p, u, i in boxes:
        b = len(pos)
        pos += p; uv += u; idx += [b + k for k in i]
    return pos, uv, idx

walls = [
    box((-5.2, 0, -4.2), (5.2, 4, -4.0)),      # -z wall
    box((-5.2, 0, 4.0), (5.2, 4, 4.2)),        # +z wall
    box((-5.2, 0, -4.0), (-5.0, 4, 4.0)),      # -x wall
    # +x wall around a window (z in [-1.5, 1.5], y in [1.2, 2.8])
    box((5.0, 0, -4.0), (5.2, 4, -1.5)),
    box((5.0, 0, 1.5), (5.2, 4, 4.0)),
    box((5.0, 0, -1.5), (5.2, 1.2, 1.5)),
    box((5.0, 2.8, -1.5), (5.2, 4, 1.5)),
    # roof slabs around a 2 x 2 skylight centred at (-2, 4, 0)
    box((-5.2, 4, -4.2), (5.2, 4.3, -1.0)),
    box((-5.2, 4, 1.0), (5.2, 4.3, 4.2)),
    box((-5.2, 4, -1.0), (-3.0, 4.3, 1.0)),
    box((-1.0, 4, -1.0), (5.2, 4.3, 1.0)),
]
floor = [box((-5.2, -0.2, -4.2), (5.2, 0.0, 4.2), 0.5)]
pillars = [box((x - 0.25, 0, z - 0.25), (x + 0.25, 4, z + 0.25)) for x in (-2.5, 2.5) for z in (-1.8, 1.8)]
plinth = [box((-0.8, 0, -0.6), (0.8, 1.0, 0.6))]

prims = [("wall", merge(walls)), ("floor", merge(floor)), ("pillar", merge(pillars)), ("plinth", merge(plinth))]
materials = {
    "wall": {"name": "plaster", "doubleSided": True, "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.78, 0.74, 1.0]}},
    "floor": {"name": "tiles", "doubleSided": True,
              "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "baseColorTexture": {"index": 0}}},
    "pillar": {"name": "stone", "doubleSided": True, "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.55, 0.7, 1.0]}},
    "plinth": {"name": "lacquer", "doubleSided": True, "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.2, 1.0]}},
}

buf = bytearray()
views, accessors, primitives, mats = [], [], [], []
def add_view(data, target):
    while len(buf) % 4: buf.append(0)
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": len(data), "target": target})
    buf.extend(data)
    return len(views) - 1
for name, (pos, uv, idx) in prims:
    pv = add_view(b"".join(struct.pack("<3f", *p) for p in pos), 34962)
    tv = add_view(b"".join(struct.pack("<2f", *t) for t in uv), 34962)
    iv = add_view(b"".join(struct.pack("<I", i) for i in idx), 34963)
    mn = [min(p[k] for p in pos) for k in range(3)]
    mx = [max(p[k] for p in pos) for k in range(3)]
    accessors.append({"bufferView": pv, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": mn, "max": mx})
    accessors.append({"bufferView": tv, "componentType": 5126, "count": len(uv), "type": "VEC2"})
    accessors.append({"bufferView": iv, "componentType": 5125, "count": len(idx), "type": "SCALAR"})
    mats.append(materials[name])
    primitives.append({"attributes": {"POSITION": len(accessors) - 3, "TEXCOORD_0": len(accessors) - 2},
                       "indices": len(accessors) - 1, "material": len(mats) - 1})

# spot pointing at the plinth from a corner: the node's -Z axis is the light's direction
d = (0.0 - (-4.0), 1.0 - 3.6, 0.0 - (-3.2))
n = math.sqrt(sum(c * c for c in d)); d = [c / n for c in d]
# quaternion turning -Z onto d
axis = (-d[1], d[0], 0.0)  # (0,0,-1) x d
s = math.sqrt(sum(c * c for c in axis)); c = -d[2]
angle = math.atan2(s, c)
q = [a / s * math.sin(angle / 2) for a in axis] + [math.cos(angle / 2)]

gltf = {
    "asset": {"version": "2.0", "generator": "warpfit data/meshes/make_gallery.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"name": "ceiling lamp", "type": "point", "color": [1.0, 0.85, 0.65], "intensity": 30.0},
        {"name": "spot", "type": "spot", "color": [0.8, 0.9, 1.0], "intensity": 60.0,
         "spot": {"innerConeAngle": 0.25, "outerConeAngle": 0.45}},
    ]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [
        {"name": "gallery", "mesh": 0},
        {"name": "lamp", "translation": [2.0, 3.6, 2.5], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "spot", "translation": [-4.0, 3.6, -3.2], "rotation": q, "extensions": {"KHR_lights_punctual": {"light": 1}}},
    ],
    "meshes": [{"name": "gallery", "primitives": primitives}],
    "materials": mats,
    "textures": [{"source": 0}],
    "images": [{"uri": "gallery_floor.png"}],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
open("gallery.gltf", "w").write(json.dumps(gltf, indent=1) + "\n")
png("gallery_floor.png", 64, 64, lambda x, y: (200, 190, 170) if ((x // 16) + (y // 16)) % 2 == 0 else (70, 60, 55))
