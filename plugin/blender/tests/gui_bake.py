# The add-on in Blender's real UI (run by plugin/blender/tests/run_gui_test.sh under Xvfb):
#
#   BLENDER_USER_SCRIPTS=DIR xvfb-run -a -s "-screen 0 1600x1000x24" blender --factory-startup \
#       --enable-event-simulate -p 0 0 1600 1000 --python plugin/blender/tests/gui_bake.py -- \
#       RADBAKE REPO_ROOT SCREENSHOT.png
#
# The script runs before Blender's event loop starts, so every step runs from bpy.app.timers (one
# driver timer, resumed every 50 ms while a bake runs; each resume is a "tick": they keep coming only
# while the UI is responsive). Operators get a window, a 3D viewport area and its region through
# context.temp_override, as a click in that viewport would.
#
# a) The modal bake ('INVOKE_DEFAULT') of the Cornell box at subdivide 16 (a few seconds): the ticks keep coming while
#    radbake runs, window_manager.radbake_state.progress rises through the stages (never backwards),
#    and every mesh ends with the FLOAT_COLOR 'radbake' attribute.
# b) Cancel: a long bake (subdivide 24) stopped with bpy.ops.radbake.cancel() during the solve: the
#    child process is gone, is_baking falls, the message says cancelled, the scene is unchanged and no
#    temporary folder is left. With --enable-event-simulate the same again with an Esc key press.
# c) A screenshot of the viewport through the glTF camera after a bake (subdivide 8, the baked mesh
#    replacing the objects so the patches' light shows: the original walls are single quads), solid
#    shading, FLAT lighting, attribute colors, Standard view at +2 EV; the Radbake sidebar tab opened
#    and widened with simulated clicks; its pixels are checked for the red and green walls and the light.
# d) File > New while a bake runs: radbake stops, its temporary folder goes, Bake works again.
#
# RADBAKE_GUI_PARTS picks parts (default abcd; "c" only remakes the screenshot).
# RADBAKE_GUI_CANCEL_SUBDIVIDE sets the subdivision of the bakes that b and d interrupt (default 24).
# Prints one summary line per part; exits (os._exit: a timer cannot end Blender with sys.exit) 0 when
# every check passed, else 1.

import glob
import os
import sys
import tempfile
import time
import traceback

import addon_utils
import bpy
import numpy as np

if "bool" not in np.__dict__:  # Blender 3.4's glTF importer uses np.bool (gone in numpy 1.24)
    np.bool = bool

radbake_binary, repo, screenshot_path = sys.argv[sys.argv.index("--") + 1:][:3]
SUBDIVIDE = 8
MODAL_SUBDIVIDE = 16  # long enough to watch the ticks (hierarchical transport bakes N = 8 in 0.5 s)
CANCEL_SUBDIVIDE = int(os.environ.get("RADBAKE_GUI_CANCEL_SUBDIVIDE", "24"))
TICK = 0.05
BAKE_TIMEOUT = 240.0

failures = []
summary = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message, flush=True)
    return condition


# ---------------------------------------------------------------- the UI: window, viewport, context

def viewport():
    """(window, VIEW_3D area, its WINDOW region) of the first window's screen."""
    window = bpy.context.window_manager.windows[0]
    areas = [a for a in window.screen.areas if a.type == 'VIEW_3D']
    area = max(areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return window, area, region


def ui_context():
    window, area, region = viewport()
    return bpy.context.temp_override(window=window, screen=window.screen, area=area, region=region)


def state():
    return bpy.context.window_manager.radbake_state


# ---------------------------------------------------------------- the scene

def load_cornell():
    """An empty scene (everything removed) with the Cornell box imported."""
    for collection in list(bpy.context.scene.collection.children):
        bpy.context.scene.collection.children.unlink(collection)
    bpy.data.batch_remove(list(bpy.data.objects) + list(bpy.data.meshes) + list(bpy.data.materials) +
                          list(bpy.data.cameras) + list(bpy.data.lights) + list(bpy.data.collections) +
                          list(bpy.data.images))
    with ui_context():
        bpy.ops.import_scene.gltf(filepath=os.path.join(repo, "examples", "cornell_box.gltf"))
    meshes = [o for o in bpy.context.scene.objects if o.type == 'MESH']
    check(len(meshes) == 8, "the Cornell box has 8 meshes: %d" % len(meshes))
    return meshes


def snapshot():
    """What a cancelled bake must not change: objects, their meshes and attributes, the selection."""
    out = []
    for o in sorted(bpy.data.objects, key=lambda o: o.name):
        me = o.data if o.type == 'MESH' else None
        out.append((o.name, o.select_get(), tuple(o.matrix_world.col[3]),
                    None if me is None else (len(me.vertices), len(me.polygons),
                                             tuple(sorted(a.name for a in me.attributes)),
                                             tuple(u.name for u in me.uv_layers))))
    return out, sorted(m.name for m in bpy.data.materials), sorted(i.name for i in bpy.data.images)


def radbake_children():
    """Pids of this Blender's radbake child processes (from /proc)."""
    me, out = os.getpid(), []
    for stat in glob.glob("/proc/[0-9]*/stat"):
        try:
            with open(stat) as f:
                text = f.read()
        except OSError:
            continue
        comm = text[text.index("(") + 1:text.rindex(")")]
        fields = text[text.rindex(")") + 2:].split()
        if comm == "radbake" and int(fields[1]) == me and fields[0] != "Z":
            out.append(int(stat.split("/")[2]))
    return out


def temp_dirs():
    return set(glob.glob(os.path.join(tempfile.gettempdir(), "radbake-*")))


# ---------------------------------------------------------------- the steps (a generator on a timer)

def start_bake():
    """The bake button as the UI calls it; returns (operator result, seconds the call blocked)."""
    t = time.monotonic()
    with ui_context():
        result = bpy.ops.radbake.bake('INVOKE_DEFAULT')
    return result, time.monotonic() - t


def follow_bake(samples, until=None):
    """Resumes every TICK while the bake runs, recording (t, is_baking, stage, progress) per tick.
    Stops when the bake has ended or when until(sample) says so."""
    t0 = time.monotonic()
    while True:
        yield TICK
        s = state()
        sample = (time.monotonic() - t0, s.is_baking, s.stage, s.progress)
        samples.append(sample)
        if not s.is_baking or (until and until(sample)):
            return
        if sample[0] > BAKE_TIMEOUT:
            check(False, "the bake ended within %d s" % BAKE_TIMEOUT)
            return


def part_a():
    objects = load_cornell()
    bpy.context.scene.radbake.refine = 'SUBDIVIDE'
    bpy.context.scene.radbake.subdivide = MODAL_SUBDIVIDE
    dirs = temp_dirs()
    result, blocked = start_bake()
    if not check(result == {'RUNNING_MODAL'}, "(a) the bake runs modal: %s" % result):
        return
    check(state().is_baking, "(a) is_baking after invoke")
    samples = []
    yield from follow_bake(samples)
    running = [s for s in samples if s[1]]
    bake_time = samples[-1][0]
    gaps = np.diff([0.0] + [s[0] for s in samples])
    # Each tick asks for the next one 50 ms later; a frozen UI would deliver none until radbake ended.
    # How many come depends on the redraw cost (software GL under Xvfb: up to seconds a frame on a
    # loaded machine), so the check is that they kept coming, not their rate.
    check(len(running) >= 3 and gaps.max() < 0.6 * bake_time,
          "(a) the UI kept ticking: %d ticks in %.2f s, longest gap %.2f s" % (len(running), bake_time, gaps.max()))
    progress = [s[3] for s in running]
    stages = []
    for s in running:
        if not stages or stages[-1] != s[2]:
            stages.append(s[2])
    inner = sorted(set(p for p in progress if 0 < p < 100))
    check(len(inner) >= 3, "(a) progress seen rising: %s" % inner)
    check(all(b >= a for a, b in zip(progress, progress[1:])),
          "(a) progress never goes back: %s" % ["%s %.1f" % (s[2], s[3]) for s in running])
    check("solve" in stages, "(a) the solve stage was shown: %s" % stages)
    order = ["export", "starting", "import", "tessellate", "solve", "export"]
    check([s for s in stages if s in order] == stages, "(a) known stages: %s" % stages)
    check(not state().is_baking, "(a) is_baking cleared")
    check(state().message.startswith("radbake: baked ("), "(a) the message is radbake's summary: %r" % state().message)
    with_attribute = 0
    for obj in objects:
        attribute = obj.data.color_attributes.get("radbake")
        if check(attribute is not None and attribute.data_type == 'FLOAT_COLOR' and attribute.domain == 'POINT',
                 "(a) %s has the FLOAT_COLOR point attribute 'radbake'" % obj.name):
            with_attribute += 1
    check(temp_dirs() == dirs, "(a) the temporary folder is gone")
    check(not radbake_children(), "(a) no radbake process left")
    shown = ", ".join("%s %.0f%%" % (s[2], s[3]) for s in running)
    summary.append("(a) modal bake, subdivide %d: %.2f s, %d timer ticks while baking (longest gap %.0f ms), "
                   "invoke blocked %.0f ms, %d distinct progress values, stages %s, %d/%d objects baked; "
                   "samples: %s" % (MODAL_SUBDIVIDE, bake_time, len(running), 1000 * gaps.max(), 1000 * blocked,
                                    len(set(progress)), " > ".join(stages), with_attribute, len(objects), shown))


def cancel_test(label, how):
    load_cornell()
    bpy.context.scene.radbake.refine = 'SUBDIVIDE'
    bpy.context.scene.radbake.subdivide = CANCEL_SUBDIVIDE
    before = snapshot()
    dirs = temp_dirs()
    result, _ = start_bake()
    if not check(result == {'RUNNING_MODAL'}, "(%s) the bake runs modal: %s" % (label, result)):
        return
    samples = []
    yield from follow_bake(samples, until=lambda s: s[2] == "solve")
    if not check(state().is_baking and state().stage == "solve",
                 "(%s) still solving when cancelling (subdivide %d)" % (label, CANCEL_SUBDIVIDE)):
        return
    children = radbake_children()
    check(len(children) == 1, "(%s) one radbake child while solving: %s" % (label, children))
    progress_at_cancel, t_solve = state().progress, samples[-1][0]
    t_cancel = time.monotonic()
    how()
    gone_at = None
    while state().is_baking and time.monotonic() - t_cancel < 10:
        yield 0.01
        if gone_at is None and not any(os.path.exists("/proc/%d" % p) for p in children):
            gone_at = time.monotonic() - t_cancel
    latency = time.monotonic() - t_cancel
    if gone_at is None and not any(os.path.exists("/proc/%d" % p) for p in children):
        gone_at = latency
    check(not state().is_baking, "(%s) is_baking cleared after cancelling" % label)
    check(latency < 5.0, "(%s) cancelled within 5 s: %.3f s" % (label, latency))
    check(gone_at is not None, "(%s) the radbake process %s has ended" % (label, children))
    check(not radbake_children(), "(%s) no radbake child left" % label)
    check("cancelled" in state().message.lower(), "(%s) the message says cancelled: %r" % (label, state().message))
    yield 0.3  # a few more event loop turns: nothing may land late
    check(snapshot() == before, "(%s) the scene is unchanged" % label)
    check(not any("radbake" in o.data.color_attributes for o in bpy.data.objects if o.type == 'MESH'),
          "(%s) no object got a radbake attribute" % label)
    check(temp_dirs() == dirs, "(%s) the temporary folder is gone" % label)
    summary.append("(%s) cancel at subdivide %d: solve reached after %.2f s, cancelled at %.1f%%, "
                   "is_baking false after %.0f ms (process gone after %s ms), message %r"
                   % (label, CANCEL_SUBDIVIDE, t_solve, progress_at_cancel, 1000 * latency,
                      "%.0f" % (1000 * gone_at) if gone_at is not None else "?", state().message))


def cancel_with_operator():
    with ui_context():
        check(bpy.ops.radbake.cancel.poll(), "(b) the cancel button is enabled while baking")
        bpy.ops.radbake.cancel()


def cancel_with_esc():
    window, area, region = viewport()
    x, y = region.x + region.width // 2, region.y + region.height // 2
    window.event_simulate(type='ESC', value='PRESS', x=x, y=y)
    window.event_simulate(type='ESC', value='RELEASE', x=x, y=y)


def part_c():
    load_cornell()
    scene = bpy.context.scene
    scene.radbake.refine = 'SUBDIVIDE'
    scene.radbake.subdivide = SUBDIVIDE
    scene.radbake.replace_objects = True  # the tessellated mesh carries the light of every patch
    result, _ = start_bake()
    if not check(result == {'RUNNING_MODAL'}, "(c) the bake runs modal: %s" % result):
        return
    samples = []
    yield from follow_bake(samples)
    check(state().message.startswith("radbake: baked ("), "(c) the bake succeeded: %r" % state().message)
    shown = [o for o in scene.objects if o.type == 'MESH' and o.visible_get()]
    check(len(shown) == 8 and all("radbake" in o.data.color_attributes for o in shown),
          "(c) 8 baked meshes shown: %s" % [o.name for o in shown])

    camera = bpy.data.objects.get("cornell_camera")
    check(camera is not None and camera.type == 'CAMERA', "(c) the glTF camera cornell_camera")
    scene.camera = camera
    scene.render.resolution_x = scene.render.resolution_y = 1000  # the glTF camera is square
    # Linear radiance through the plain sRGB view; +2 EV puts the walls about where radbake's own
    # automatic exposure (+2.4 EV at 0.8) puts them, without clipping the lit walls.
    scene.view_settings.view_transform = 'Standard'
    scene.view_settings.look = 'None'
    scene.view_settings.exposure = 2.0
    scene.view_settings.gamma = 1.0

    # The sidebar beside the viewport, not over it: the camera frame then centers in what is left.
    bpy.context.preferences.system.use_region_overlap = False
    with ui_context():
        bpy.ops.screen.screen_full_area()  # maximize the viewport (the top and status bars stay)
    yield 0.3
    window, area, region = viewport()
    space = area.spaces.active
    space.show_region_toolbar = False
    space.show_region_ui = True
    space.show_gizmo = False
    space.overlay.show_overlays = False
    shading = space.shading
    shading.type = 'SOLID'
    shading.light = 'FLAT'
    check(shading.color_type == 'VERTEX', "(c) the add-on set the viewport's colors to the attribute")
    shading.color_type = 'VERTEX'
    shading.show_shadows = shading.show_cavity = shading.show_specular_highlight = False
    space.region_3d.view_perspective = 'CAMERA'
    yield 0.3
    with ui_context():
        bpy.ops.view3d.view_center_camera()  # the camera frame fills the viewport
    yield 0.3

    # The sidebar opens on its first tab (Item). Click down the tab strip at its right edge until the
    # Radbake panel draws (seen through a draw hook that adds nothing); other tabs are harmless.
    drawn = []
    hook = lambda panel, context: drawn.append(time.monotonic())  # noqa: E731
    bpy.types.RADBAKE_PT_panel.append(hook)
    sidebar_draws = []
    handle = bpy.types.SpaceView3D.draw_handler_add(lambda: sidebar_draws.append(1), (), 'UI', 'POST_PIXEL')
    sidebar = next(r for r in area.regions if r.type == 'UI')
    clicks = 0
    yield 0.3
    x = sidebar.x + sidebar.width - int(10 * bpy.context.preferences.system.ui_scale)
    offsets = range(int(60 * bpy.context.preferences.system.ui_scale), sidebar.height // 2, 16)
    for offset in (offsets if bpy.app.use_event_simulate and not drawn else ()):
        y = sidebar.y + sidebar.height - offset
        window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x, y=y)
        window.event_simulate(type='LEFTMOUSE', value='PRESS', x=x, y=y)
        window.event_simulate(type='LEFTMOUSE', value='RELEASE', x=x, y=y)
        clicks += 1
        before = len(sidebar_draws)
        for _ in range(30):  # until the sidebar has redrawn: seconds with software GL on a busy machine
            yield 0.1
            if drawn or len(sidebar_draws) > before + 1:
                break
        if drawn:
            break
    # Widen the sidebar by dragging its edge (a few pixels inside the region), as a user would, so
    # the panel's labels fit.
    width = sidebar.width
    if bpy.app.use_event_simulate:
        # The edge's grip: at the region's left border (a few pixels inside it when the region
        # overlaps the viewport, and then only beside its panels, near the top).
        scale = bpy.context.preferences.system.ui_scale
        inside = 7 if bpy.context.preferences.system.use_region_overlap else -2
        x0, y = sidebar.x + int(inside * scale), sidebar.y + sidebar.height - int(100 * scale)
        window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x0, y=y)
        yield 0.2
        window.event_simulate(type='LEFTMOUSE', value='PRESS', x=x0, y=y)
        yield 0.2
        for step in range(1, 11):
            window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=x0 - 17 * step, y=y)
            yield 0.05
        window.event_simulate(type='LEFTMOUSE', value='RELEASE', x=x0 - 170, y=y)
        for _ in range(50):
            yield 0.1
            sidebar = next(r for r in area.regions if r.type == 'UI')
            if sidebar.width != width:
                break
        yield 0.5
        window, area, region = viewport()
        sidebar = next(r for r in area.regions if r.type == 'UI')
    # Park the pointer in the viewport's corner so no tab or button is highlighted in the picture.
    if bpy.app.use_event_simulate:
        window.event_simulate(type='MOUSEMOVE', value='NOTHING', x=region.x + 2, y=region.y + 2)
    panel_shown = bool(drawn)
    check(panel_shown or not bpy.app.use_event_simulate, "(c) the Radbake sidebar tab is shown")
    with ui_context():
        bpy.ops.view3d.view_center_camera()  # again: the sidebar got wider
    yield 1.0  # let the viewport draw settle (software GL)
    os.makedirs(os.path.dirname(os.path.abspath(screenshot_path)), exist_ok=True)
    if os.path.exists(screenshot_path):
        os.remove(screenshot_path)
    with ui_context():
        bpy.ops.screen.screenshot_area(filepath=screenshot_path, check_existing=False)
    bpy.types.RADBAKE_PT_panel.remove(hook)
    bpy.types.SpaceView3D.draw_handler_remove(handle, 'UI')
    if not check(os.path.isfile(screenshot_path), "(c) the screenshot was written: %s" % screenshot_path):
        return

    # The picture: the camera frame (the viewport beside the sidebar) shows red, green, bright light.
    image = bpy.data.images.load(screenshot_path, check_existing=False)
    w, h = image.size
    pixels = np.array(image.pixels[:], dtype=np.float32).reshape(h, w, -1)[:, :, :3]
    bpy.data.images.remove(image)
    x0, y0 = region.x - area.x, region.y - area.y
    view = pixels[y0:y0 + region.height, x0:x0 + region.width]
    r, g, b = view[..., 0], view[..., 1], view[..., 2]
    total = r.size
    red = float(np.mean((r > 0.35) & (r > 2 * g) & (r > 2 * b)))
    green = float(np.mean((g > 0.2) & (g > 1.4 * r) & (g > 1.4 * b)))
    white = float(np.mean((r > 0.97) & (g > 0.97) & (b > 0.97)))
    grey = float(np.mean((abs(r - g) < 0.05) & (abs(g - b) < 0.05) & (r > 0.05) & (r < 0.95)))
    check(red > 0.03 and green > 0.03, "(c) red and green walls in the picture: %.1f%% red, %.1f%% green"
          % (100 * red, 100 * green))
    check(0.001 < white < 0.2, "(c) the light is bright: %.2f%% white" % (100 * white))
    check(grey > 0.1, "(c) grey surfaces lit: %.1f%%" % (100 * grey))
    summary.append("(c) screenshot %s: %dx%d px, viewport %dx%d through %s, sidebar tab %s (%d clicks, %d px "
                   "wide), view Standard +2 EV: %.0f%% red, %.0f%% green, %.1f%% white, %.0f%% grey of %d px"
                   % (screenshot_path, w, h, region.width, region.height, camera.name,
                      "Radbake" if panel_shown else "first tab", clicks, sidebar.width, 100 * red, 100 * green,
                      100 * white, 100 * grey, total))


def part_d():
    """File > New while a bake runs: Blender ends the modal operator (its cancel()); radbake must
    stop with it and its temporary folder go, and a new bake must be possible."""
    load_cornell()
    bpy.context.scene.radbake.refine = 'SUBDIVIDE'
    bpy.context.scene.radbake.subdivide = CANCEL_SUBDIVIDE
    dirs = temp_dirs()
    result, _ = start_bake()
    if not check(result == {'RUNNING_MODAL'}, "(d) the bake runs modal: %s" % result):
        return
    samples = []
    yield from follow_bake(samples, until=lambda s: s[2] == "solve")
    children = radbake_children()
    with ui_context():
        bpy.ops.wm.read_homefile(use_empty=True)
    t = time.monotonic()
    while time.monotonic() - t < 5 and (radbake_children() or temp_dirs() != dirs):
        yield 0.1
    left = radbake_children()
    check(not left, "(d) File > New during a bake stops radbake: %s still running" % left)
    check(temp_dirs() == dirs, "(d) File > New during a bake removes the temporary folder: %s"
          % sorted(temp_dirs() - dirs))
    check(not state().is_baking, "(d) is_baking is cleared after File > New")
    with ui_context():
        check(bpy.ops.radbake.bake.poll(), "(d) the Bake button works again after File > New")
    for pid in left:  # the test leaves nothing running
        os.kill(pid, 15)
    summary.append("(d) File > New during a bake: radbake %s, temporary folder %s"
                   % ("still running (killed by the test)" if left else "stopped",
                      "left behind" if temp_dirs() != dirs else "removed"))


def main():
    parts = os.environ.get("RADBAKE_GUI_PARTS", "abcd")  # e.g. c: only the screenshot
    yield 0.5  # the first redraws
    if "a" in parts:
        yield from part_a()
    if "b" in parts:
        yield from cancel_test("b", cancel_with_operator)
        if bpy.app.use_event_simulate:
            yield from cancel_test("b-esc", cancel_with_esc)
        else:
            summary.append("(b-esc) skipped: Blender was not started with --enable-event-simulate")
    if "c" in parts:
        yield from part_c()
    if "d" in parts:
        yield from part_d()


steps = main()


def driver():
    try:
        return next(steps)
    except StopIteration:
        pass
    except Exception:
        traceback.print_exc()
        failures.append("exception: see the traceback above")
    for line in summary:
        print(line)
    print("gui_bake: %s" % ("%d failure(s)" % len(failures) if failures else "all checks passed"), flush=True)
    sys.stderr.flush()
    os._exit(1 if failures else 0)


addon_utils.enable("radbake", default_set=True, persistent=True)
bpy.context.preferences.addons["radbake"].preferences.executable = radbake_binary
bpy.context.preferences.view.show_splash = False
bpy.app.timers.register(driver, first_interval=0.5, persistent=True)
