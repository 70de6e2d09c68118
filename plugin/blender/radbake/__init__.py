# radbake for Blender: bake radiosity (bilinear vertex radiosity) from a panel or from Blender's
# command line. The bake runs the radbake command as a child process on a temporary .glb export;
# the scene is only touched once the bake has succeeded.

bl_info = {
    "name": "radbake: Radiosity Bake",
    "author": "radbake",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport > Sidebar > Radbake",
    "description": "Noise-free diffuse light bakes (vertex colors or lightmaps) with the radbake command",
    "category": "Lighting",
}

import os
import shutil
import tempfile

import bpy

from . import command

VIEWS = (("ACES 1.0 SDR-video", "ACES (filmic)", "Highlights roll off (radbake's default view)"),
         ("Standard", "Standard", "The plain sRGB encoding; clips at 1"))


class RadbakePreferences(bpy.types.AddonPreferences):
    bl_idname = __name__
    executable: bpy.props.StringProperty(
        name="radbake executable", subtype='FILE_PATH',
        description="The radbake program. Empty: radbake on PATH, else the repository's build/plugin/cli/radbake")

    def draw(self, context):
        self.layout.prop(self, "executable")
        found = command.find_radbake(self.executable, os.path.dirname(__file__))
        self.layout.label(text="Using: " + (found or "not found"), icon='CHECKMARK' if found else 'ERROR')


class RadbakeSettings(bpy.types.PropertyGroup):
    method: bpy.props.EnumProperty(name="Method", items=(
        ("bilinear", "Bilinear", "Bilinear vertex radiosity (smooth, exact at vertices)"),
        ("constant", "Constant", "Classic constant patches (the baseline)")), default="bilinear")
    # Adaptive by default, as radbake's own default: uniform patches leave a Blender room with a
    # ceiling light several times too dark unless they are made very fine.
    refine: bpy.props.EnumProperty(name="Refine", items=(
        ("ADAPTIVE", "Adaptive", "Split patches where the light changes (the direct light, then its first bounce) "
                                 "until the error is below a target or a patch budget is spent (bilinear method; "
                                 "the constant method takes Subdivide's N)"),
        ("SUBDIVIDE", "Subdivide", "Split every face into N×N patches"),
        ("MAX_EDGE", "Max edge", "Refine until no patch edge is longer than a length")),
        default="ADAPTIVE")
    subdivide: bpy.props.IntProperty(name="Subdivide", default=4, min=1, max=64)
    max_edge: bpy.props.FloatProperty(name="Max edge", default=0.25, min=1e-4, subtype='DISTANCE')
    refine_target: bpy.props.FloatProperty(name="Target error", default=0.02, min=1e-6, max=1.0, precision=3,
                                           description="Largest error of the bilinear field, as a share of the mean light")
    max_patches: bpy.props.IntProperty(name="Patch budget", default=0, min=0,
                                       description="Stop splitting at about this many patches "
                                                   "(0: radbake's default, the starting patches plus 20000)")
    exposure_auto: bpy.props.BoolProperty(name="Auto exposure", default=True)
    exposure: bpy.props.FloatProperty(name="Exposure (EV)", default=0.0, soft_min=-10, soft_max=10)
    view: bpy.props.EnumProperty(name="View", items=VIEWS, default="ACES 1.0 SDR-video")
    output: bpy.props.EnumProperty(name="Output", items=(
        ("VERTEX_COLORS", "Vertex colors", "A float color attribute with the linear radiance"),
        ("LIGHTMAP", "Lightmap", "An HDR lightmap image and a second UV map")), default="VERTEX_COLORS")
    lightmap_size: bpy.props.IntProperty(name="Lightmap size", default=1024, min=16, max=16384)
    sky_enabled: bpy.props.BoolProperty(name="Sky", default=False, description="A uniform sky lights open scenes")
    sky: bpy.props.FloatVectorProperty(name="Sky radiance", subtype='COLOR', size=3, default=(1, 1, 1), min=0)
    selected_only: bpy.props.BoolProperty(name="Selected only", default=False,
                                          description="Bake the selected objects (else every mesh in the scene)")
    replace_objects: bpy.props.BoolProperty(
        name="Replace with baked mesh", default=False,
        description="Replace the objects with the baked, tessellated mesh (the originals move to a hidden collection)")
    attribute_name: bpy.props.StringProperty(name="Attribute", default="radbake")
    keep_path: bpy.props.StringProperty(
        name="Keep baked .glb", subtype='FILE_PATH', default="",
        description="Also save radbake's output file (and lightmap EXR) here; empty: only the scene gets the bake")

    def command_settings(self):
        return {"method": self.method, "refine": self.refine, "subdivide": self.subdivide, "max_edge": self.max_edge,
                "refine_target": self.refine_target, "max_patches": self.max_patches,
                "exposure_auto": self.exposure_auto, "exposure": self.exposure, "view": self.view,
                "sky_enabled": self.sky_enabled, "sky": tuple(self.sky), "lightmap_size": self.lightmap_size}


class RadbakeState(bpy.types.PropertyGroup):  # per window manager: what the running bake is doing
    is_baking: bpy.props.BoolProperty(default=False)
    cancel_requested: bpy.props.BoolProperty(default=False)
    progress: bpy.props.FloatProperty(default=0.0, subtype='PERCENTAGE', min=0, max=100)
    stage: bpy.props.StringProperty(default="")
    message: bpy.props.StringProperty(default="")


def _bake_objects(context, settings):
    meshes = [o for o in context.scene.objects if o.type == 'MESH' and o.visible_get()]
    if settings.selected_only:
        meshes = [o for o in meshes if o.select_get()]
    return meshes


def _export(context, objects, path):
    """The objects to a .glb with Blender's exporter; the selection is put back as it was."""
    view_layer = context.view_layer
    selected = [o for o in context.scene.objects if o.select_get()]
    active = view_layer.objects.active
    try:
        for o in selected:
            o.select_set(False)
        for o in objects:
            o.select_set(True)
        bpy.ops.export_scene.gltf(filepath=path, export_format='GLB', use_selection=True, export_apply=False,
                                  export_cameras=False, export_lights=True, export_extras=True, export_yup=True)
    finally:
        for o in context.scene.objects:
            o.select_set(o in selected)
        view_layer.objects.active = active


def _summary(line):
    """radbake's closing line without the temporary output path it names."""
    prefix = "radbake: wrote "
    if line.startswith(prefix) and " (" in line:
        return "radbake: baked" + line[line.index(" (", len(prefix)):]
    return line


def _node_name(object_name, baked):
    """The baked node an object shows: its own name, or for an imported copy of it (replace mode)
    the name without Blender's ".001" suffix. Each object must read its own node's vertices: where
    two objects touch (the light in the ceiling's hole) their coincident corners differ."""
    if object_name in baked:
        return object_name
    stem, dot, suffix = object_name.rpartition(".")
    return stem if dot and suffix.isdigit() and stem in baked else None


class RADBAKE_OT_bake(bpy.types.Operator):
    """Bake diffuse light with radbake (runs in the background; Cancel or Esc stops it)"""
    bl_idname = "radbake.bake"
    bl_label = "Bake"
    bl_options = {'REGISTER', 'UNDO'}  # a finished bake is one undo step

    @classmethod
    def poll(cls, context):
        return not context.window_manager.radbake_state.is_baking

    # -- shared by the modal (UI) and the blocking (background mode) paths

    def _start(self, context):
        settings = context.scene.radbake
        prefs = context.preferences.addons[__name__].preferences
        radbake = command.find_radbake(prefs.executable, os.path.dirname(__file__))
        if radbake is None:
            self.report({'ERROR'}, "radbake executable not found: set it in the add-on's preferences")
            return False
        self._objects = _bake_objects(context, settings)
        if not self._objects:
            self.report({'ERROR'}, "radbake: no mesh objects to bake")
            return False
        self._dir = tempfile.mkdtemp(prefix="radbake-")
        self._input = os.path.join(self._dir, "scene.glb")
        self._output = os.path.join(self._dir, "baked.glb")
        self._lightmap = os.path.join(self._dir, "lightmap.exr") if settings.output == 'LIGHTMAP' else None
        try:
            _export(context, self._objects, self._input)
        except Exception as e:  # the exporter's own failure, reported as it is
            self._cleanup()
            self.report({'ERROR'}, "radbake: exporting the scene failed: %s" % e)
            return False
        args = command.build_command(radbake, self._input, self._output, settings.command_settings(), self._lightmap)
        self._job = command.BakeJob(args)
        state = context.window_manager.radbake_state
        state.is_baking, state.cancel_requested, state.progress, state.stage, state.message = True, False, 0, "export", ""
        return True

    def _update(self, context):
        state = context.window_manager.radbake_state
        state.stage = self._job.stage
        state.progress = 100 * command.overall_fraction(self._job.stage, self._job.fraction)

    def _finish(self, context, code):
        state = context.window_manager.radbake_state
        state.is_baking = False
        try:
            if self._job.cancelled:
                state.message = "Bake cancelled; the scene is unchanged"
                self.report({'WARNING'}, state.message)
                return {'CANCELLED'}
            if code != 0:
                state.message = self._job.error_message()
                self.report({'ERROR'}, state.message)
                return {'CANCELLED'}
            for warning in self._job.warnings():
                self.report({'WARNING'}, warning)
            self._apply(context)
            self._keep(context.scene.radbake.keep_path)
            state.message = _summary((self._job.stdout_lines or ["radbake: done"])[-1])
            self.report({'INFO'}, state.message)
            return {'FINISHED'}
        except Exception as e:  # reading or applying the result; the scene is left as it was
            state.message = "radbake: applying the bake failed: %s" % e
            self.report({'ERROR'}, state.message)
            return {'CANCELLED'}
        finally:
            self._cleanup()

    def _apply(self, context):
        from . import apply  # mathutils-only module, loaded when a bake lands
        settings = context.scene.radbake
        baked = apply.read_bake(self._output)
        if not baked:
            raise RuntimeError("the baked file holds no baked mesh")
        everything = apply.merged(baked)
        targets = self._objects
        if settings.replace_objects:
            targets = self._replace(context)
        image = None
        if self._lightmap:
            image = bpy.data.images.load(self._lightmap, check_existing=False)
            image.name = "radbake lightmap"
            image.pack()  # the temporary EXR goes away; the image stays in the .blend
        for obj in targets:
            vertices = baked.get(_node_name(obj.name, baked), everything)
            if self._lightmap:
                apply.set_lightmap_uvs(obj, vertices, settings.attribute_name)
                for slot in obj.material_slots:
                    apply.add_lightmap_nodes(slot.material, image, settings.attribute_name)
            apply.set_radiance_attribute(obj, vertices, settings.attribute_name + ("_radiance" if self._lightmap else ""))
        if not self._lightmap:  # show the colors in every 3D viewport (solid mode, attribute colors)
            for window in context.window_manager.windows:
                for area in window.screen.areas:
                    if area.type == 'VIEW_3D':
                        area.spaces.active.shading.color_type = 'VERTEX'

    def _replace(self, context):
        """Imports the baked mesh; the originals move to a hidden collection (nothing is deleted)."""
        import numpy as np
        if "bool" not in np.__dict__:  # Blender 3.4's glTF importer uses np.bool (gone in numpy 1.24)
            np.bool = bool
        before = set(bpy.data.objects)
        bpy.ops.import_scene.gltf(filepath=self._output)
        imported = [o for o in bpy.data.objects if o not in before and o.type == 'MESH']
        keep = bpy.data.collections.new("radbake originals")
        context.scene.collection.children.link(keep)
        for obj in self._objects:
            for collection in list(obj.users_collection):
                collection.objects.unlink(obj)
            keep.objects.link(obj)
        keep.hide_viewport = keep.hide_render = True
        return imported

    def _keep(self, path):
        if not path:
            return
        path = bpy.path.abspath(path)
        shutil.copyfile(self._output, path)
        if self._lightmap:
            shutil.copyfile(self._lightmap, os.path.splitext(path)[0] + ".exr")

    def _cleanup(self):
        shutil.rmtree(getattr(self, "_dir", ""), ignore_errors=True)

    # -- background mode (blender -b): no event loop, so the bake blocks and prints its progress

    def execute(self, context):
        if not self._start(context):
            return {'CANCELLED'}
        last = [None]

        def show(stage, fraction):
            if (stage, round(fraction, 1)) != last[0]:
                last[0] = (stage, round(fraction, 1))
                print("radbake: %s %d%%" % (stage, 100 * fraction), flush=True)
        return self._finish(context, self._job.wait(show))

    # -- the UI: a modal operator polls the child on a timer, so Blender never freezes

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        if not self._start(context):
            return {'CANCELLED'}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 100)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        wm = context.window_manager
        if event.type == 'ESC' or wm.radbake_state.cancel_requested:
            self._job.cancel()
        if event.type not in {'TIMER', 'ESC'} and not wm.radbake_state.cancel_requested:
            return {'PASS_THROUGH'}
        code = self._job.poll()
        self._update(context)
        wm.progress_update(int(wm.radbake_state.progress))
        context.workspace.status_text_set("radbake: %s %d%%" % (wm.radbake_state.stage, wm.radbake_state.progress))
        for area in context.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()
        if code is None:
            return {'PASS_THROUGH'}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        return self._finish(context, code)

    def cancel(self, context):
        """Blender ends the modal operator itself (File > New or Open, closing the window): stop
        radbake rather than leave it running with nobody to collect its result."""
        self._job.cancel()
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        wm.radbake_state.is_baking = False
        self._cleanup()


class RADBAKE_OT_cancel(bpy.types.Operator):
    """Stop the running bake; the scene stays as it was"""
    bl_idname = "radbake.cancel"
    bl_label = "Cancel"

    @classmethod
    def poll(cls, context):
        return context.window_manager.radbake_state.is_baking

    def execute(self, context):
        context.window_manager.radbake_state.cancel_requested = True
        return {'FINISHED'}


class RADBAKE_PT_panel(bpy.types.Panel):
    bl_label = "Radiosity Bake"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Radbake"

    def draw(self, context):
        settings, state = context.scene.radbake, context.window_manager.radbake_state
        layout = self.layout
        layout.use_property_split = True
        column = layout.column(align=True)
        column.enabled = not state.is_baking
        column.prop(settings, "method")
        column.prop(settings, "refine")
        if settings.refine == 'ADAPTIVE':
            column.prop(settings, "refine_target")
            column.prop(settings, "max_patches")
        else:
            column.prop(settings, "subdivide" if settings.refine == 'SUBDIVIDE' else "max_edge")
        column.separator()
        column.prop(settings, "output")
        if settings.output == 'LIGHTMAP':
            column.prop(settings, "lightmap_size")
        column.prop(settings, "attribute_name")
        column.prop(settings, "view")
        column.prop(settings, "exposure_auto")
        if not settings.exposure_auto:
            column.prop(settings, "exposure")
        column.prop(settings, "sky_enabled")
        if settings.sky_enabled:
            column.prop(settings, "sky")
        column.prop(settings, "selected_only")
        column.prop(settings, "replace_objects")
        column.prop(settings, "keep_path")
        row = layout.row(align=True)
        row.scale_y = 1.4
        row.operator("radbake.bake", icon='LIGHT_SUN')
        row.operator("radbake.cancel", icon='CANCEL')
        if state.is_baking:
            layout.label(text="%s: %d%%" % (state.stage, state.progress), icon='TIME')
            layout.prop(state, "progress", text="Progress", slider=True)
        elif state.message:
            for line in state.message.splitlines()[:4]:
                layout.label(text=line)


CLASSES = (RadbakePreferences, RadbakeSettings, RadbakeState, RADBAKE_OT_bake, RADBAKE_OT_cancel, RADBAKE_PT_panel)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.radbake = bpy.props.PointerProperty(type=RadbakeSettings)
    bpy.types.WindowManager.radbake_state = bpy.props.PointerProperty(type=RadbakeState)


def unregister():
    del bpy.types.WindowManager.radbake_state
    del bpy.types.Scene.radbake
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
