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
