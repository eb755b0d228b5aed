"""Writes small glTF/GLB files for the loader tests (test helper, not part of rtlab)."""
import base64
import io
import json
import struct

import numpy as np


def png_bytes(rgb: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgb.astype(np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


def quad_document(buffer_uri=None, image=None, image_uri=None):
    """A 2x2 m quad (two triangles) under a node with translation (0,1,0), an emissive textured
    material, a point light, a spot light, a sun and a camera. Returns (doc, binary)."""
    pos = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    nrm = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    idx = np.array([0, 2, 1, 0, 3, 2], np.uint16)
    blob = pos.tobytes() + nrm.tobytes() + uv.tobytes() + idx.tobytes()
    blob += b"\0" * (-len(blob) % 4)
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"mesh": 0, "translation": [0, 1, 0]},
            {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 3, 0]},
            {"extensions": {"KHR_lights_punctual": {"light": 1}}, "translation": [2, 3, 0],
             "rotation": [-0.7071068, 0, 0, 0.7071068]},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}, "rotation": [-0.7071068, 0, 0, 0.7071068]},
            {"camera": 0, "translation": [0, 2, 5]},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3,
                                    "material": 0}]}],
        "materials": [{"name": "glow", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 1.0],
                                                                "roughnessFactor": 0.3, "metallicFactor": 0.0},
                       "emissiveFactor": [1.0, 0.5, 0.25],
                       "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
                       "doubleSided": True}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 0.5, 0.25], "intensity": 12.0, "name": "bulb"},
            {"type": "spot", "intensity": 5.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
            {"type": "directional", "intensity": 3.0}]}},
        "cameras": [{"type": "perspective", "name": "front", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 32},
            {"buffer": 0, "byteOffset": 128, "byteLength": 12},
        ],
        "buffers": [{"byteLength": len(blob)}],
    }
    if buffer_uri == "data":
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    elif buffer_uri is not None:
        doc["buffers"][0]["uri"] = buffer_uri
    if image is not None or image_uri is not None:
        img = {"uri": image_uri} if image_uri else {
            "uri": "data:image/png;base64," + base64.b64encode(image).decode()}
        doc["images"] = [img]
        doc["textures"] = [{"source": 0}]
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    return doc, blob


def write_gltf(path, doc):
    path.write_text(json.dumps(doc))
    return path


def write_glb(path, doc, blob):
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(blob), 0x004E4942) + blob
    path.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)
    return path


def _data_uri_png(rgba: np.ndarray) -> str:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba.astype(np.uint8)).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def textured_scene(materials: list, textures: list, quads: list, lights: list, camera=None):
    """A glTF document of textured quads: quads are (centre, size, material index, facing)
    with facing "up" (+Y) or "down" (-Y); textures: H x W x C uint8 arrays (RGB or RGBA);
    materials: glTF material objects referring to them by index; lights: KHR_lights_punctual
    objects with an added "node" dict (translation/rotation). Each quad has uvs (0,0)..(1,1)
    over x and z and a tangent along +x. Returns the document (buffers as data URIs)."""
    pos, nrm, uv, tan, idx, prims = [], [], [], [], [], []
    for centre, size, mat, facing in quads:
        cx, cy, cz = centre
        h = size / 2
        p = np.array([[cx - h, cy, cz - h], [cx + h, cy, cz - h], [cx + h, cy, cz + h], [cx - h, cy, cz + h]],
                     np.float32)
        y = 1.0 if facing == "up" else -1.0
        tri = [0, 2, 1, 0, 3, 2] if facing == "up" else [0, 1, 2, 0, 2, 3]
        pos.append(p)
        nrm.append(np.tile([0, y, 0], (4, 1)).astype(np.float32))
        uv.append(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32))
        tan.append(np.tile([1, 0, 0, 1], (4, 1)).astype(np.float32))
        idx.append(np.array(tri, np.uint32))
        prims.append(mat)
    blob, views, accessors, meshes = b"", [], [], []
    for k in range(len(quads)):
        for arr, kind in ((pos[k], "VEC3"), (nrm[k], "VEC3"), (uv[k], "VEC2"), (tan[k], "VEC4"), (idx[k], "SCALAR")):
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": arr.nbytes})
            acc = {"bufferView": len(views) - 1, "componentType": 5125 if arr.dtype == np.uint32 else 5126,
                   "count": int(arr.shape[0]), "type": kind}
            if kind == "VEC3" and len(accessors) % 5 == 0:
                acc["min"], acc["max"] = arr.min(0).tolist(), arr.max(0).tolist()
            accessors.append(acc)
            blob += arr.tobytes()
        a = 5 * k
        meshes.append({"primitives": [{"attributes": {"POSITION": a, "NORMAL": a + 1, "TEXCOORD_0": a + 2,
                                                      "TANGENT": a + 3}, "indices": a + 4, "material": prims[k]}]})
    nodes = [{"mesh": k} for k in range(len(quads))]
    for k, light in enumerate(lights):
        light = dict(light)
        nodes.append({**light.pop("node"), "extensions": {"KHR_lights_punctual": {"light": k}}})
        lights[k] = light
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
           "meshes": meshes, "materials": materials, "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
           "images": [{"uri": _data_uri_png(t)} for t in textures],
           "textures": [{"source": k} for k in range(len(textures))],
           "extensionsUsed": ["KHR_lights_punctual"],
           "extensions": {"KHR_lights_punctual": {"lights": lights}}}
    if not textures:
        del doc["images"], doc["textures"]
    if camera is not None:
        doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": camera[2], "znear": 0.01}}]
        doc["nodes"].append({"camera": 0, "translation": list(camera[0]), "rotation": list(camera[1])})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    return doc


def uv_sphere(centre, radius, segments=48, rings=24):
    """A UV sphere: (positions, normals, uvs, triangle indices), counter-clockwise outside."""
    th = np.linspace(0, np.pi, rings + 1)
    ph = np.linspace(0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(th, ph, indexing="ij")
    nrm = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    pos = np.asarray(centre, np.float64) + radius * nrm
    uv = np.stack([p / (2 * np.pi), t / np.pi], -1).reshape(-1, 2)
    idx = []
    w = segments + 1
    for r in range(rings):
        for s in range(segments):
            a, b = r * w + s, (r + 1) * w + s
            idx += [[a, b, a + 1], [a + 1, b, b + 1]]
    return pos.astype(np.float32), nrm.astype(np.float32), uv.astype(np.float32), np.array(idx, np.uint32)


def mesh_scene(meshes: list, materials: list, lights: list, camera=None):
    """A glTF document of triangle meshes: (positions, normals, uvs, indices, material index)
    each; lights and camera as textured_scene. Returns the document (buffers as data URIs)."""
    blob, views, accessors, gl_meshes = b"", [], [], []
    for pos, nrm, uv, idx, mat in meshes:
        first = len(accessors)
        for arr, kind in ((pos, "VEC3"), (nrm, "VEC3"), (uv, "VEC2"), (idx.reshape(-1), "SCALAR")):
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": arr.nbytes})
            acc = {"bufferView": len(views) - 1, "componentType": 5125 if arr.dtype == np.uint32 else 5126,
                   "count": int(arr.shape[0]), "type": kind}
            if arr is pos:
                acc["min"], acc["max"] = arr.min(0).tolist(), arr.max(0).tolist()
            accessors.append(acc)
            blob += arr.tobytes()
        gl_meshes.append({"primitives": [{"attributes": {"POSITION": first, "NORMAL": first + 1,
                                                         "TEXCOORD_0": first + 2},
                                          "indices": first + 3, "material": mat}]})
    nodes = [{"mesh": k} for k in range(len(meshes))]
    lights = [dict(light) for light in lights]
    for k, light in enumerate(lights):
        nodes.append({**light.pop("node"), "extensions": {"KHR_lights_punctual": {"light": k}}})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
           "meshes": gl_meshes, "materials": materials, "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
           "extensionsUsed": ["KHR_lights_punctual"], "extensions": {"KHR_lights_punctual": {"lights": lights}}}
    if camera is not None:
        doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": camera[2], "znear": 0.01}}]
        doc["nodes"].append({"camera": 0, "translation": list(camera[0]), "rotation": list(camera[1])})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    return doc


def ggx_spheres_document():
    """Three white metal spheres (F = 1 at every angle: Schlick's F0 = 1), roughness 0.25, 0.5
    and 0.8, under one point light, the camera looking at them: the scene of the Mitsuba
    references (tests/refs/make_mitsuba_refs.py)."""
    roughness = (0.25, 0.5, 0.8)
    materials = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1.0,
                                           "roughnessFactor": r}} for r in roughness]
    meshes = [(*uv_sphere((x, 0.0, 0.0), 0.5, 64, 32), k) for k, x in enumerate((-1.15, 0.0, 1.15))]
    lights = [{"type": "point", "intensity": 20.0, "color": [1, 1, 1], "node": {"translation": [1.0, 2.0, 2.5]}}]
    return mesh_scene(meshes, materials, lights, ((0.0, 0.0, 4.0), (0.0, 0.0, 0.0, 1.0), 0.7))


def ggx_quads_document():
    """Three floor quads side by side, a red dielectric (roughness 0.3), a gold metal (0.4) and a
    grey half-metal (0.7), under one point light, seen from above at an angle: every pixel's
    direct light has a closed form (tests/test_brdf.py)."""
    materials = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1], "metallicFactor": 0.0,
                                           "roughnessFactor": 0.3}},
                 {"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1], "metallicFactor": 1.0,
                                           "roughnessFactor": 0.4}},
                 {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0.5,
                                           "roughnessFactor": 0.7}}]
    quads = [((-2.1, 0, 0), 2.0, 0, "up"), ((0, 0, 0), 2.0, 1, "up"), ((2.1, 0, 0), 2.0, 2, "up")]
    lights = [{"type": "point", "intensity": 40.0, "color": [1, 1, 1], "node": {"translation": [0.3, 1.5, -1.2]}}]
    half = -np.arctan2(2.5, 3.5) / 2  # looking down at the quads
    return textured_scene(materials, [], quads, lights, ((0, 2.5, 3.5), (float(np.sin(half)), 0, 0,
                                                                          float(np.cos(half))), 0.9))


GRID_METALLIC, GRID_ROUGHNESS = (0.0, 0.5, 1.0), (0.3, 0.55, 0.8)


def ggx_grid_document():
    """A 3 x 3 grid of orange spheres, metallic 0, 0.5, 1 (rows, top to bottom) x roughness 0.3,
    0.55, 0.8 (columns), under one point light: the scene of the Mitsuba references with glTF's
    BRDF written as a Mitsuba plugin (tests/refs/make_mitsuba_refs.py)."""
    materials, meshes = [], []
    for i, metal in enumerate(GRID_METALLIC):
        for j, rough in enumerate(GRID_ROUGHNESS):
            materials.append({"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.45, 0.15, 1],
                                                       "metallicFactor": metal, "roughnessFactor": rough}})
            meshes.append((*uv_sphere(((j - 1) * 1.1, (1 - i) * 1.1, 0.0), 0.5, 48, 24), len(materials) - 1))
    lights = [{"type": "point", "intensity": 30.0, "color": [1, 1, 1], "node": {"translation": [1.5, 2.0, 3.0]}}]
    return mesh_scene(meshes, materials, lights, ((0.0, 0.0, 5.2), (0.0, 0.0, 0.0, 1.0), 0.75))


def checker_glossy_document():
    """A glossy dielectric floor (roughness 0.25) textured as a black-and-white checker, under one
    point light that makes a highlight across the squares, seen from above at an angle: its
    specular part is what demodulating by the texture gets wrong (tests/test_denoise.py)."""
    n = 64
    yy, xx = np.mgrid[0:n, 0:n]
    c = ((xx // 8 + yy // 8) % 2).astype(np.float32)
    tex = (np.stack([c * 0.85 + 0.03] * 3, -1) ** (1 / 2.2) * 255).astype(np.uint8)
    materials = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0,
                                           "roughnessFactor": 0.25}}]
    lights = [{"type": "point", "intensity": 15.0, "color": [1, 1, 1], "node": {"translation": [0.0, 1.2, -1.0]}}]
    half = -np.arctan2(2.0, 3.0) / 2  # looking down at the floor
    return textured_scene(materials, [tex], [((0, 0, 0), 4.0, 0, "up")], lights,
                          ((0, 2.0, 3.0), (float(np.sin(half)), 0, 0, float(np.cos(half))), 0.9))
