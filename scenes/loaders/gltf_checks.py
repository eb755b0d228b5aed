"""Checks a glTF document's JSON before the reader uses any of it: every value the reader
reads has the right type, shape and range, every index points into its array, every
primitive's attributes agree in count, and the nodes form trees (no cycles, one parent each),
so the reader (scenes/loaders/gltf.py) can index without guards and nothing is allocated from
a count that the file does not back."""
from __future__ import annotations

import math

from scenes.loaders.checks import Checker

COMPONENTS = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}  # componentType -> bytes
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform"}
WRAP_MODES = {10497: 0, 33071: 1, 33648: 2}  # REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT -> scenes.model.WRAP_*
FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125
ATTRIBUTE_FORMS = {  # attribute -> (accessor types, allowed component types)
    "POSITION": (("VEC3",), {FLOAT}),
    "NORMAL": (("VEC3",), {FLOAT}),
    "TANGENT": (("VEC4",), {FLOAT}),
    **{f"TEXCOORD_{k}": (("VEC2",), {FLOAT, UBYTE, USHORT}) for k in range(4)},
    "COLOR_0": (("VEC3", "VEC4"), {FLOAT, UBYTE, USHORT}),
}
INDEX_TYPES = {UBYTE, USHORT, UINT}


def check_document(doc, chk: Checker) -> list[int]:
    """Raises UserError naming the first bad value; returns the root nodes of the scene to draw."""
    chk.mapping(doc, "the document")
    chk.mapping(doc.get("asset"), "asset")
    for k, ext in enumerate(chk.array(doc.get("extensionsRequired", []), "extensionsRequired")):
        chk.string(ext, f"extensionsRequired[{k}]")
        if ext not in SUPPORTED_EXTENSIONS:
            chk.fail("extensionsRequired", f"the file requires {ext}, which rtlab does not support")
    arrays = {}
    for key in ("buffers", "bufferViews", "accessors", "images", "textures", "samplers", "materials", "meshes",
                "nodes", "scenes", "cameras"):
        arrays[key] = chk.objects(doc.get(key, []), key)
    ext = chk.mapping(doc.get("extensions", {}), "extensions")
    lights_ext = chk.mapping(ext.get("KHR_lights_punctual", {}), "extensions.KHR_lights_punctual")
    arrays["lights"] = chk.objects(lights_ext.get("lights", []), "KHR_lights_punctual.lights")
    n = {key: len(items) for key, items in arrays.items()}

    for k, b in enumerate(arrays["buffers"]):
        chk.integer(b.get("byteLength"), f"buffers[{k}].byteLength", 1, 2**53)
        if "uri" in b:
            chk.string(b["uri"], f"buffers[{k}].uri")
    for k, v in enumerate(arrays["bufferViews"]):
        w = f"bufferViews[{k}]"
        chk.index(v.get("buffer"), n["buffers"], f"{w}.buffer")
        chk.integer(v.get("byteOffset", 0), f"{w}.byteOffset", 0, 2**53)
        chk.integer(v.get("byteLength"), f"{w}.byteLength", 1, 2**53)
        if "byteStride" in v:
            chk.integer(v["byteStride"], f"{w}.byteStride", 4, 252)
    for k, a in enumerate(arrays["accessors"]):
        _check_accessor(a, k, n, chk)
    for k, img in enumerate(arrays["images"]):
        if "bufferView" in img:
            chk.index(img["bufferView"], n["bufferViews"], f"images[{k}].bufferView")
        elif "uri" in img:
            chk.string(img["uri"], f"images[{k}].uri")
    for k, smp in enumerate(arrays["samplers"]):
        for key in ("wrapS", "wrapT"):
            if key in smp and (not _is_key(smp[key], int) or smp[key] not in WRAP_MODES):
                chk.fail(f"samplers[{k}].{key}", f"{str(smp[key])[:40]} is not a glTF wrap mode")
    for k, t in enumerate(arrays["textures"]):
        if "source" in t:
            chk.index(t["source"], n["images"], f"textures[{k}].source")
        if "sampler" in t:
            chk.index(t["sampler"], n["samplers"], f"textures[{k}].sampler")
    for k, m in enumerate(arrays["materials"]):
        _check_material(m, f"materials[{k}]", n, chk)
    for k, mesh in enumerate(arrays["meshes"]):
        prims = chk.objects(mesh.get("primitives"), f"meshes[{k}].primitives")
        for j, prim in enumerate(prims):
            _check_primitive(prim, f"meshes[{k}].primitives[{j}]", arrays["accessors"], n, chk)
    for k, c in enumerate(arrays["cameras"]):
        kind = chk.string(c.get("type"), f"cameras[{k}].type")
        if kind == "perspective":
            p = chk.mapping(c.get("perspective"), f"cameras[{k}].perspective")
            yfov = chk.number(p.get("yfov"), f"cameras[{k}].perspective.yfov", 0.0, math.pi)
            if yfov <= 0.0 or yfov >= math.pi:
                chk.fail(f"cameras[{k}].perspective.yfov", f"{yfov:g} is not within 0..pi radians")
        elif kind != "orthographic":
            chk.fail(f"cameras[{k}].type", f"{kind[:40]!r} is not perspective or orthographic")
    for k, light in enumerate(arrays["lights"]):
        _check_light(light, f"KHR_lights_punctual.lights[{k}]", chk)
    for k, node in enumerate(arrays["nodes"]):
        _check_node(node, f"nodes[{k}]", n, chk)
    return _check_trees(doc, arrays, n, chk)


def _is_key(value, kind) -> bool:
    return isinstance(value, kind) and not isinstance(value, bool)


def _check_accessor(a: dict, k: int, n: dict, chk: Checker) -> None:
    w = f"accessors[{k}]"
    if "sparse" in a:
        chk.fail(w, "sparse accessors are not supported")
    if not _is_key(a.get("componentType"), int) or a["componentType"] not in COMPONENTS:
        chk.fail(f"{w}.componentType", f"{str(a.get('componentType'))[:40]} is not a glTF component type")
    if not _is_key(a.get("type"), str) or a["type"] not in WIDTH:
        chk.fail(f"{w}.type", f"{str(a.get('type'))[:40]!r} is not a glTF accessor type")
    chk.integer(a.get("count"), f"{w}.count", 1, 2**31 - 1)
    chk.integer(a.get("byteOffset", 0), f"{w}.byteOffset", 0, 2**53)
    chk.boolean(a.get("normalized", False), f"{w}.normalized")
    if "bufferView" in a:
        chk.index(a["bufferView"], n["bufferViews"], f"{w}.bufferView")


def _check_texture_ref(ref, what: str, n: dict, chk: Checker) -> None:
    ref = chk.mapping(ref, what)
    chk.index(ref.get("index"), n["textures"], f"{what}.index")
    chk.integer(ref.get("texCoord", 0), f"{what}.texCoord", 0, 3)
    ext = chk.mapping(ref.get("extensions", {}), f"{what}.extensions")
    if "KHR_texture_transform" in ext:
        t = chk.mapping(ext["KHR_texture_transform"], f"{what}.KHR_texture_transform")
        chk.vector(t.get("offset", [0, 0]), 2, f"{what}.KHR_texture_transform.offset", -1e6, 1e6)
        chk.number(t.get("rotation", 0), f"{what}.KHR_texture_transform.rotation", -1e6, 1e6)
        chk.vector(t.get("scale", [1, 1]), 2, f"{what}.KHR_texture_transform.scale", -1e6, 1e6)
        if "texCoord" in t:
            chk.integer(t["texCoord"], f"{what}.KHR_texture_transform.texCoord", 0, 3)


def _check_material(m: dict, w: str, n: dict, chk: Checker) -> None:
    pbr = chk.mapping(m.get("pbrMetallicRoughness", {}), f"{w}.pbrMetallicRoughness")
    chk.vector(pbr.get("baseColorFactor", [1, 1, 1, 1]), 4, f"{w}.pbrMetallicRoughness.baseColorFactor", 0.0)
    chk.number(pbr.get("metallicFactor", 1.0), f"{w}.pbrMetallicRoughness.metallicFactor", 0.0, 1.0)
    chk.number(pbr.get("roughnessFactor", 1.0), f"{w}.pbrMetallicRoughness.roughnessFactor", 0.0, 1.0)
    for key in ("baseColorTexture", "metallicRoughnessTexture"):
        if key in pbr:
            _check_texture_ref(pbr[key], f"{w}.pbrMetallicRoughness.{key}", n, chk)
    for key in ("normalTexture", "occlusionTexture", "emissiveTexture"):
        if key in m:
            _check_texture_ref(m[key], f"{w}.{key}", n, chk)
    if "normalTexture" in m:
        chk.number(m["normalTexture"].get("scale", 1.0), f"{w}.normalTexture.scale", -1e3, 1e3)
    if "occlusionTexture" in m:
        chk.number(m["occlusionTexture"].get("strength", 1.0), f"{w}.occlusionTexture.strength", 0.0, 1.0)
    mode = m.get("alphaMode", "OPAQUE")
    if mode not in ("OPAQUE", "MASK", "BLEND"):
        chk.fail(f"{w}.alphaMode", f"{str(mode)[:40]!r} is not OPAQUE, MASK or BLEND")
    chk.number(m.get("alphaCutoff", 0.5), f"{w}.alphaCutoff", 0.0)
    chk.vector(m.get("emissiveFactor", [0, 0, 0]), 3, f"{w}.emissiveFactor", 0.0)
    ext = chk.mapping(m.get("extensions", {}), f"{w}.extensions")
    strength = chk.mapping(ext.get("KHR_materials_emissive_strength", {}),
                           f"{w}.extensions.KHR_materials_emissive_strength")
    chk.number(strength.get("emissiveStrength", 1.0), f"{w}.emissiveStrength", 0.0)
    chk.boolean(m.get("doubleSided", False), f"{w}.doubleSided")
    chk.string(m.get("name", ""), f"{w}.name")


def _check_primitive(prim: dict, w: str, accessors: list, n: dict, chk: Checker) -> None:
    mode = chk.integer(prim.get("mode", 4), f"{w}.mode", 0, 6)
    attrs = chk.mapping(prim.get("attributes"), f"{w}.attributes")
    if "POSITION" not in attrs:
        chk.fail(f"{w}.attributes", "no POSITION")
    for name, value in attrs.items():
        chk.index(value, n["accessors"], f"{w}.attributes.{str(name)[:40]}")
    if "material" in prim:
        chk.index(prim["material"], n["materials"], f"{w}.material")
    if "indices" in prim:
        chk.index(prim["indices"], n["accessors"], f"{w}.indices")
    if mode != 4:
        return  # points, lines and strips are skipped, not read
    count = accessors[attrs["POSITION"]]["count"]
    for name, (kind, components) in ATTRIBUTE_FORMS.items():
        if name not in attrs:
            continue
        a = accessors[attrs[name]]
        if a["type"] not in kind or a["componentType"] not in components:
            chk.fail(f"{w}.attributes.{name}", f"accessor {attrs[name]} is {a['type']} of component type "
                     f"{a['componentType']}, not {' or '.join(kind)} of {sorted(components)}")
        if a["count"] != count:
            chk.fail(f"{w}.attributes.{name}", f"accessor {attrs[name]} has {a['count']} entries, "
                     f"POSITION has {count}")
        if "bufferView" not in a:
            chk.fail(f"{w}.attributes.{name}", f"accessor {attrs[name]} has no data (no bufferView)")
    if "indices" in prim:
        a = accessors[prim["indices"]]
        if a["type"] != "SCALAR" or a["componentType"] not in INDEX_TYPES:
            chk.fail(f"{w}.indices", f"accessor {prim['indices']} is not SCALAR of an unsigned integer type")
        if "bufferView" not in a:
            chk.fail(f"{w}.indices", f"accessor {prim['indices']} has no data (no bufferView)")


def _check_light(light: dict, w: str, chk: Checker) -> None:
    kind = light.get("type")
    if not _is_key(kind, str) or kind not in ("point", "spot", "directional"):
        chk.fail(f"{w}.type", f"{str(kind)[:40]!r} is not point, spot or directional")
    chk.vector(light.get("color", [1, 1, 1]), 3, f"{w}.color", 0.0)
    chk.number(light.get("intensity", 1.0), f"{w}.intensity", 0.0)
    if "range" in light:
        chk.number(light["range"], f"{w}.range", 0.0)
    if kind == "spot":
        spot = chk.mapping(light.get("spot", {}), f"{w}.spot")
        inner = chk.number(spot.get("innerConeAngle", 0.0), f"{w}.spot.innerConeAngle", 0.0, math.pi / 2)
        outer = chk.number(spot.get("outerConeAngle", math.pi / 4), f"{w}.spot.outerConeAngle", 0.0, math.pi / 2)
        if outer <= 0.0 or inner >= outer:
            chk.fail(f"{w}.spot", f"need 0 <= innerConeAngle < outerConeAngle, got {inner:g} and {outer:g}")
    chk.string(light.get("name", ""), f"{w}.name")


def _check_node(node: dict, w: str, n: dict, chk: Checker) -> None:
    if "mesh" in node:
        chk.index(node["mesh"], n["meshes"], f"{w}.mesh")
    if "camera" in node:
        chk.index(node["camera"], n["cameras"], f"{w}.camera")
    for k, c in enumerate(chk.array(node.get("children", []), f"{w}.children")):
        chk.index(c, n["nodes"], f"{w}.children[{k}]")
    if "matrix" in node:
        chk.vector(node["matrix"], 16, f"{w}.matrix")
    for key, size in (("translation", 3), ("rotation", 4), ("scale", 3)):
        if key in node:
            chk.vector(node[key], size, f"{w}.{key}")
    ext = chk.mapping(node.get("extensions", {}), f"{w}.extensions")
    if "KHR_lights_punctual" in ext:
        ref = chk.mapping(ext["KHR_lights_punctual"], f"{w}.extensions.KHR_lights_punctual")
        chk.index(ref.get("light"), n["lights"], f"{w}.extensions.KHR_lights_punctual.light")
    chk.string(node.get("name", ""), f"{w}.name")


def _check_trees(doc: dict, arrays: dict, n: dict, chk: Checker) -> list[int]:
    """glTF's nodes form disjoint trees: one parent per node, no cycles, roots without parents.
    (A node listed as a child twice, or a chain of them, would otherwise be visited 2^depth times.)"""
    parent = [-1] * n["nodes"]
    for k, node in enumerate(arrays["nodes"]):
        for c in node.get("children", []):
            if parent[c] != -1:
                chk.fail(f"nodes[{c}]", f"has more than one parent (nodes {parent[c]} and {k}); "
                         "glTF nodes must form trees")
            parent[c] = k
    state = [0] * n["nodes"]  # 0: not seen, 1: on the current walk, 2: reaches a root
    for k in range(n["nodes"]):  # walk up from each node; a cycle never reaches a root
        path, j = [], k
        while j != -1 and state[j] == 0:
            state[j] = 1
            path.append(j)
            j = parent[j]
        if j != -1 and state[j] == 1:
            chk.fail(f"nodes[{j}]", "is part of a cycle in the node hierarchy")
        for j in path:
            state[j] = 2
    if n["scenes"]:
        s = chk.index(doc.get("scene", 0), n["scenes"], "scene")
        roots = chk.array(arrays["scenes"][s].get("nodes", []), f"scenes[{s}].nodes")
        for k, r in enumerate(roots):
            chk.index(r, n["nodes"], f"scenes[{s}].nodes[{k}]")
            if parent[r] != -1:
                chk.fail(f"scenes[{s}].nodes[{k}]", f"node {r} is a child of node {parent[r]}, not a root")
        if len(set(roots)) != len(roots):
            chk.fail(f"scenes[{s}].nodes", "lists a node more than once")
        return list(roots)
    return [k for k in range(n["nodes"]) if parent[k] == -1]
