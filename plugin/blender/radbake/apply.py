# Putting a finished bake onto Blender objects. The baked file is read with gltf_file (exact
# _RADIANCE) and matched to each object's vertices by world position: the bake keeps the original
# vertices as patch corners, so every original vertex has baked twins at the same place.

import numpy as np
from mathutils import Vector
from mathutils.kdtree import KDTree

from . import gltf_file


def read_bake(path):
    """Every baked node of the file: {node name: vertices dict (gltf_file.baked_vertices)}."""
    doc, buffers = gltf_file.load_gltf(path)
    baked = {}
    for node_index, world in gltf_file.scene_mesh_nodes(doc):
        vertices = gltf_file.baked_vertices(doc, buffers, node_index, world)
        if vertices is not None:
            baked[doc["nodes"][node_index].get("name", "")] = vertices
    return baked


def merged(baked):
    """All baked vertices in one set (for objects whose node cannot be told by name)."""
    parts = list(baked.values())
    out = {key: np.concatenate([p[key] for p in parts]) for key in ("positions", "normals", "radiance")}
    out["uv1"] = (np.concatenate([p["uv1"] for p in parts]) if all(p["uv1"] is not None for p in parts) else None)
    return out


def _tree(positions):
    tree = KDTree(len(positions))
    for i, p in enumerate(positions):
        tree.insert(Vector(p), i)
    tree.balance()
    return tree


def _tolerance(positions):
    extent = np.ptp(positions, axis=0).max() if len(positions) else 1.0
    return 1e-5 * max(extent, 1e-6)


def set_radiance_attribute(obj, vertices, name):
    """A FLOAT_COLOR point attribute `name` holding the linear radiance at each vertex (the mean of
    the baked vertices there, whose normals face the vertex's way when there are several), made the
    active and render color. Returns how many vertices found no baked twin."""
    mesh = obj.data
    tree, eps = _tree(vertices["positions"]), _tolerance(vertices["positions"])
    world = obj.matrix_world
    normal_matrix = world.to_3x3().inverted().transposed()
    colors = np.zeros((len(mesh.vertices), 4), dtype=np.float32)
    colors[:, 3] = 1
    missing = 0
    for v in mesh.vertices:
        found = tree.find_range(world @ v.co, eps)
        if not found:
            missing += 1
            continue
        n = (normal_matrix @ v.normal).normalized()
        facing = [i for _, i, _ in found if np.dot(vertices["normals"][i], n) > 0.5] or [i for _, i, _ in found]
        colors[v.index, :3] = vertices["radiance"][facing].mean(axis=0)
    attributes = mesh.color_attributes
    if name in attributes:
        attributes.remove(attributes[name])
    attribute = attributes.new(name, 'FLOAT_COLOR', 'POINT')
    attribute.data.foreach_set("color", colors.ravel())
    attributes.active_color = attribute
    attributes.render_color_index = attributes.active_color_index
    mesh.update()
    return missing


def _charts(vertices):
    """A chart label per baked vertex: the atlas splits vertices where charts meet, so the charts are
    the pieces of the baked triangle mesh connected through shared vertex indices."""
    parent = list(range(len(vertices["positions"])))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for a, b, c in vertices["triangles"]:
        ra, rb, rc = root(a), root(b), root(c)
        parent[rb] = ra
        parent[root(rc)] = ra
    return [root(i) for i in range(len(parent))]


def set_lightmap_uvs(obj, vertices, uv_name):
    """A UV map `uv_name` reading the lightmap. Each face takes its corners from one chart: among
    the baked vertices at each corner's position, those of a chart all its corners share (several
    charts meet at a seam), preferring normals that match the face. Returns how many faces span
    charts (their corners then take the best normal match each)."""
    mesh = obj.data
    tree, eps = _tree(vertices["positions"]), _tolerance(vertices["positions"])
    chart = _charts(vertices)
    world = obj.matrix_world
    normal_matrix = world.to_3x3().inverted().transposed()
    layer = mesh.uv_layers.get(uv_name) or mesh.uv_layers.new(name=uv_name)
    uv = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    split = 0
    for polygon in mesh.polygons:
        n = (normal_matrix @ polygon.normal).normalized()
        candidates = [[i for _, i, _ in tree.find_range(world @ mesh.vertices[mesh.loops[li].vertex_index].co, eps)]
                      for li in polygon.loop_indices]
        if not all(candidates):
            split += 1
            continue
        shared = set.intersection(*({chart[i] for i in c} for c in candidates))
        if not shared:
            split += 1
        for li, found in zip(polygon.loop_indices, candidates):
            pool = [i for i in found if chart[i] in shared] or found
            best = max(pool, key=lambda i: float(np.dot(vertices["normals"][i], n)))
            u, v = vertices["uv1"][best]
            uv[li] = (u, 1.0 - v)  # glTF's v runs down, Blender's up
    layer.data.foreach_set("uv", uv.ravel())
    return split


def add_lightmap_nodes(material, image, uv_name):
    """An Image Texture node showing the lightmap through its UV map, left for the artist to wire
    (the light multiplies albedo: E / π × base color is the diffuse light)."""
    if material is None or not material.use_nodes:
        return
    nodes = material.node_tree.nodes
    for node in [n for n in nodes if n.get("radbake")]:
        nodes.remove(node)
    uv_node = nodes.new("ShaderNodeUVMap")
    uv_node.uv_map = uv_name
    uv_node["radbake"] = True
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.label = "radbake lightmap (irradiance)"
    texture["radbake"] = True
    uv_node.location = (-900, -400)
    texture.location = (-650, -400)
    material.node_tree.links.new(uv_node.outputs["UV"], texture.inputs["Vector"])
