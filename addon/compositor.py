"""Denoising through Blender's compositor: a Denoise node fed with Primer's passes, set up for the user.

Every Blender ships Intel Open Image Denoise in its compositor's Denoise node. When the user ticks
Render > Denoise (scene.primer.use_denoising), Primer writes the Denoising Albedo and Denoising
Normal passes (core/integrators/features.py) and `set_up` puts a Denoise node between the Render
Layers node's Image and whatever it fed (the Composite output, the Viewer): Image = Combined,
Albedo = Denoising Albedo, Normal = Denoising Normal. Nothing else of the user's tree changes;
a tree with several Render Layers nodes is left alone, with a warning. Unticking removes the node
and joins its links again. The compositor runs after the render, for F12 and `blender -b -f`.

The compositor's home differs between Blender versions: 4.2 to 4.5 keep it in scene.node_tree
(switched on by scene.use_nodes), 5.0 in scene.compositing_node_group, a CompositorNodeTree whose
Group Output is the composited image.
"""
from __future__ import annotations

import logging

import bpy

log = logging.getLogger("primer")

DENOISE_NODE = "Primer Denoise"
ALBEDO_PASS, NORMAL_PASS = "Denoising Albedo", "Denoising Normal"


def _modern(scene) -> bool:
    """Whether this Blender keeps the compositor in scene.compositing_node_group (5.0 and later)."""
    return hasattr(scene, "compositing_node_group")


def compositor_tree(scene, create: bool = False):
    """Return the scene's compositor node tree, or None; with create, make Blender's default one first."""
    if _modern(scene):
        tree = scene.compositing_node_group
        if tree is None and create:
            tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
            tree.interface.new_socket(name="Image", in_out="OUTPUT", socket_type="NodeSocketColor")
            layers = tree.nodes.new("CompositorNodeRLayers")
            output = tree.nodes.new("NodeGroupOutput")
            layers.location, output.location = (-300.0, 0.0), (300.0, 0.0)
            tree.links.new(layers.outputs["Image"], output.inputs[0])
            scene.compositing_node_group = tree
        return tree
    if create and not scene.use_nodes:
        scene.use_nodes = True                  # 4.x: makes the default tree (Render Layers -> Composite)
    return scene.node_tree


def _render_layers(tree, scene) -> list:
    """Return the tree's Render Layers nodes that show this scene."""
    return [node for node in tree.nodes
            if node.bl_idname == "CompositorNodeRLayers" and getattr(node, "scene", None) in (None, scene)]


def _output(node, name: str):
    """Return the node's output socket `name`, or None when the node does not show it (yet)."""
    socket = node.outputs.get(name)
    return socket if socket is not None and socket.enabled else None


def _refresh_outputs(layers) -> None:
    """Make a Render Layers node list the passes the engine registers now (its Denoising outputs)."""
    layers.layer = layers.layer                 # setting the layer makes Blender ask the engine again


def _denoise_nodes(tree) -> list:
    """Return the tree's Denoise nodes that are not muted."""
    return [node for node in tree.nodes if node.bl_idname == "CompositorNodeDenoise" and not node.mute]


def set_up(scene) -> str:
    """Put a Denoise node fed with Primer's passes into the scene's compositor; return a warning or ''."""
    tree = compositor_tree(scene, create=True)
    scene.render.use_compositing = True
    layers = _render_layers(tree, scene)
    if len(layers) != 1:
        return (f"the compositor has {len(layers)} Render Layers nodes: Primer does not know where to put its "
                f"Denoise node; add one yourself, fed with Image, {ALBEDO_PASS} and {NORMAL_PASS}")
    source = layers[0]
    _refresh_outputs(source)
    albedo, normal = _output(source, ALBEDO_PASS), _output(source, NORMAL_PASS)
    if albedo is None or normal is None:
        return f"the Render Layers node shows no {ALBEDO_PASS} and {NORMAL_PASS} outputs; is Primer the engine?"
    # A Denoise node already fed by the Render Layers: link its guides where they are missing.
    for node in _denoise_nodes(tree):
        if any(link.from_node == source for link in tree.links if link.to_node == node):
            if not node.inputs["Albedo"].is_linked:
                tree.links.new(albedo, node.inputs["Albedo"])
            if not node.inputs["Normal"].is_linked:
                tree.links.new(normal, node.inputs["Normal"])
            return ""
    # Else insert one between the Image output and everything it fed.
    image = source.outputs["Image"]
    targets = [link.to_socket for link in tree.links if link.from_socket == image]
    denoise = tree.nodes.new("CompositorNodeDenoise")
    denoise.name = denoise.label = DENOISE_NODE
    denoise.location = (source.location.x + 300.0, source.location.y + 150.0)
    tree.links.new(image, denoise.inputs["Image"])
    tree.links.new(albedo, denoise.inputs["Albedo"])
    tree.links.new(normal, denoise.inputs["Normal"])
    for socket in targets:
        tree.links.new(denoise.outputs["Image"], socket)
    if not targets:
        outputs = [node for node in tree.nodes if node.bl_idname in ("NodeGroupOutput", "CompositorNodeComposite")]
        for node in outputs[:1]:
            tree.links.new(denoise.outputs["Image"], node.inputs[0])
    if not any(node.bl_idname == "CompositorNodeViewer" for node in tree.nodes):
        viewer = tree.nodes.new("CompositorNodeViewer")      # the Image Editor's Viewer Node shows it too
        viewer.name = viewer.label = DENOISE_NODE + " Viewer"
        viewer.location = (denoise.location.x + 300.0, denoise.location.y + 150.0)
        tree.links.new(denoise.outputs["Image"], viewer.inputs["Image"])
    return ""


def take_down(scene) -> None:
    """Remove the Denoise node (and Viewer) set_up inserted, joining what fed it to what it fed."""
    tree = compositor_tree(scene)
    if tree is None:
        return
    for node in [node for node in tree.nodes if node.name.startswith(DENOISE_NODE)]:
        if node.bl_idname == "CompositorNodeViewer":
            tree.nodes.remove(node)
            continue
        feeding = [link.from_socket for link in tree.links if link.to_socket == node.inputs["Image"]]
        fed = [link.to_socket for link in tree.links if link.from_node == node]
        tree.nodes.remove(node)
        for socket in fed:
            if feeding:
                tree.links.new(feeding[0], socket)


def has_denoiser() -> bool:
    """Whether this Blender was built with Open Image Denoise (else its Denoise node passes images through)."""
    try:
        import _cycles
    except ImportError:                     # no Cycles module to ask: Blender's official builds ship OIDN
        return True
    return bool(getattr(_cycles, "with_openimagedenoise", True))


def problems(scene) -> list:
    """Return why Denoise, being on, would not denoise this scene's composited image (empty: it will)."""
    found = []
    if not has_denoiser():
        found.append("this Blender was built without Open Image Denoise: its Denoise node passes the image "
                     "through unchanged (the frame is rendered, not denoised)")
    if not scene.render.use_compositing:
        found.append("Denoise is on but Output > Post Processing > Compositing is off: the Denoise node does not run")
    tree = None if (not _modern(scene) and not scene.use_nodes) else compositor_tree(scene)
    fed = tree is not None and any(
        node.inputs["Image"].is_linked and node.outputs["Image"].is_linked for node in _denoise_nodes(tree))
    if not fed:
        found.append("Denoise is on but the compositor has no Denoise node between Render Layers and the output: "
                     "untick and tick Render > Denoise to set it up")
    return found


def on_toggle(settings, context) -> None:
    """scene.primer.use_denoising's update: set the compositor up, or take Primer's Denoise node out."""
    scene = settings.id_data
    if settings.use_denoising:
        warning = set_up(scene)
        if warning:
            log.warning("Primer: %s", warning)
    else:
        take_down(scene)
