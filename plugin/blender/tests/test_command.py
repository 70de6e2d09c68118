# Pure-Python tests of the add-on's command line builder, progress parser and child-process job
# (no Blender needed): python3 -m unittest discover -s plugin/blender/tests -p 'test_*.py'

import importlib.util
import os
import stat
import sys
import tempfile
import textwrap
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
# command.py on its own: the package's __init__ imports bpy, which only exists inside Blender.
_spec = importlib.util.spec_from_file_location("radbake_command", os.path.join(HERE, "..", "radbake", "command.py"))
command = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(command)

SETTINGS = {"method": "bilinear", "refine": "SUBDIVIDE", "subdivide": 4, "max_edge": 0.25, "exposure_auto": True,
            "exposure": 0.0, "view": "ACES 1.0 SDR-video", "sky_enabled": False, "sky": (1, 1, 1),
            "lightmap_size": 1024}


def fake_radbake(directory, body):
    """An executable Python script standing in for radbake."""
    path = os.path.join(directory, "radbake")
    with open(path, "w") as f:
        f.write("#!%s\nimport sys, time, json\n" % sys.executable + textwrap.dedent(body))
    os.chmod(path, os.stat(path).st_mode | stat.S_IXUSR)
    return path


class BuildCommand(unittest.TestCase):
    def test_defaults(self):
        self.assertEqual(command.build_command("/bin/radbake", "in.glb", "out.glb", SETTINGS),
                         ["/bin/radbake", "bake", "in.glb", "-o", "out.glb", "--progress", "json", "--method",
                          "bilinear", "--subdivide", "4", "--view", "ACES 1.0 SDR-video"])

    def test_every_option(self):
        s = dict(SETTINGS, method="constant", refine="MAX_EDGE", max_edge=0.1, exposure_auto=False, exposure=-1.5,
                 view="Standard", sky_enabled=True, sky=(0.5, 0.25, 1.0), lightmap_size=512)
        args = command.build_command("radbake", "a b.glb", "c.glb", s, lightmap_path="/t/lm.exr")
        self.assertEqual(args[args.index("--method") + 1], "constant")
        self.assertEqual(args[args.index("--max-edge") + 1], "0.1")
        self.assertNotIn("--subdivide", args)
        self.assertEqual(args[args.index("--exposure") + 1], "-1.5")
        self.assertEqual(args[args.index("--view") + 1], "Standard")
        self.assertEqual(args[args.index("--sky") + 1], "0.5,0.25,1.0")
        self.assertEqual(args[args.index("--lightmap") + 1], "/t/lm.exr")
        self.assertEqual(args[args.index("--lightmap-size") + 1], "512")
        self.assertEqual(args[2], "a b.glb")  # one argument, spaces and all: no shell involved


    def test_adaptive(self):
        s = dict(SETTINGS, refine="ADAPTIVE", refine_target=0.05, max_patches=0)
        args = command.build_command("radbake", "in.glb", "out.glb", s)
        self.assertEqual(args[args.index("--refine") + 1], "0.05")
        self.assertNotIn("--max-patches", args)  # 0: radbake's own budget
        self.assertNotIn("--subdivide", args)
        self.assertNotIn("--max-edge", args)
        args = command.build_command("radbake", "in.glb", "out.glb", dict(s, max_patches=8000))
        self.assertEqual(args[args.index("--max-patches") + 1], "8000")
        # The constant method is not refined (radbake refuses --refine with it): Subdivide's N.
        args = command.build_command("radbake", "in.glb", "out.glb", dict(s, method="constant"))
        self.assertNotIn("--refine", args)
        self.assertEqual(args[args.index("--subdivide") + 1], "4")


class Progress(unittest.TestCase):
    def test_parses_radbake_json_lines(self):
        self.assertEqual(command.parse_progress('{"progress":0.25,"stage":"solve"}'), ("solve", 0.25))
        self.assertEqual(command.parse_progress('  {"stage": "export", "progress": 1}\n'), ("export", 1.0))
        self.assertEqual(command.parse_progress('{"progress":1.7,"stage":"solve"}'), ("solve", 1.0))

    def test_ignores_everything_else(self):
        for line in ("", "warning: scene.glb: no emitter", "error: x", "{not json", '{"stage":"solve"}', "[1,2]",
                     '{"progress":"half","stage":"solve"}'):
            self.assertIsNone(command.parse_progress(line), line)

    def test_overall_fraction_rises_through_the_stages(self):
        seen = [command.overall_fraction(stage, f) for stage, _ in command.STAGES for f in (0, 0.5, 1)]
        self.assertEqual(seen, sorted(seen))
        self.assertAlmostEqual(command.overall_fraction("export", 1), 1.0)
        self.assertEqual(command.overall_fraction("import", 0), 0.0)

    def test_every_stage_radbake_names_has_its_share(self):
        # radbake's stages in its order (tests/cli_test.cpp, Progress.JsonLinesNameEachStage).
        self.assertEqual([name for name, _ in command.STAGES], ["import", "tessellate", "refine", "solve", "export"])
        self.assertAlmostEqual(sum(share for _, share in command.STAGES), 1.0)
        self.assertLess(command.overall_fraction("tessellate", 1), command.overall_fraction("refine", 0.5))
        self.assertLess(command.overall_fraction("refine", 0.5), command.overall_fraction("solve", 0))


class FindRadbake(unittest.TestCase):
    def test_preference_wins_and_must_be_executable(self):
        with tempfile.TemporaryDirectory() as d:
            exe = fake_radbake(d, "")
            self.assertEqual(command.find_radbake(exe, "/nowhere"), exe)
            self.assertIsNone(command.find_radbake(os.path.join(d, "missing"), "/nowhere"))

    def test_repository_build_output(self):
        with tempfile.TemporaryDirectory() as d:
            build = os.path.join(d, "build", "plugin", "cli")
            os.makedirs(build)
            exe = fake_radbake(build, "")
            addon_dir = os.path.join(d, "plugin", "blender", "radbake")
            old_path = os.environ.get("PATH", "")
            os.environ["PATH"] = d  # no radbake on PATH
            try:
                self.assertEqual(command.find_radbake("", addon_dir), os.path.normpath(exe))
            finally:
                os.environ["PATH"] = old_path


class Job(unittest.TestCase):
    def run_job(self, body):
        with tempfile.TemporaryDirectory() as d:
            job = command.BakeJob([fake_radbake(d, body)])
            seen = []
            code = job.wait(lambda stage, f: seen.append((stage, f)))
            return job, code, seen

    def test_progress_output_and_exit(self):
        job, code, seen = self.run_job("""
            for stage in ("import", "solve", "export"):
                for p in (0, 0.5, 1):
                    print(json.dumps({"progress": p, "stage": stage}), file=sys.stderr, flush=True)
                    time.sleep(0.01)
            print("warning: scene.glb: no emitter", file=sys.stderr)
            print("radbake: wrote out.glb")
            """)
        self.assertEqual(code, 0)
        self.assertEqual((job.stage, job.fraction), ("export", 1.0))
        overall = [command.overall_fraction(stage, f) for stage, f in seen]
        self.assertEqual(overall, sorted(overall))  # what the bar shows only moves forward
        self.assertEqual(seen[-1], ("export", 1.0))
        self.assertEqual(job.stdout_lines, ["radbake: wrote out.glb"])
        self.assertEqual(job.warnings(), ["warning: scene.glb: no emitter"])

    def test_the_error_is_radbakes_own_message(self):
        job, code, _ = self.run_job("""
            print('{"progress":0.0,"stage":"import"}', file=sys.stderr)
            print("error: scene.glb: mesh 3 primitive 0: accessor 7 count 12 exceeds buffer view 2 length", file=sys.stderr)
            sys.exit(2)
            """)
        self.assertEqual(code, 2)
        self.assertEqual(job.error_message(),
                         "error: scene.glb: mesh 3 primitive 0: accessor 7 count 12 exceeds buffer view 2 length")

    def test_poll_never_blocks_and_cancel_ends_the_child(self):
        with tempfile.TemporaryDirectory() as d:
            job = command.BakeJob([fake_radbake(d, """
                print('{"progress":0.1,"stage":"solve"}', file=sys.stderr, flush=True)
                time.sleep(60)
                """)])
            start = time.monotonic()
            while job.stage != "solve" and time.monotonic() - start < 10:
                self.assertIsNone(job.poll())
                time.sleep(0.01)
            self.assertEqual(job.stage, "solve")  # seen while the child still runs: poll did not wait for it
            self.assertIsNone(job.poll())
            job.cancel()
            self.assertTrue(job.cancelled)
            self.assertIsNotNone(job.poll())  # the child has ended (it would have slept a minute)


if __name__ == "__main__":
    unittest.main()
