# The radbake command line as the add-on runs it: building the arguments, finding the program,
# running it as a child process without blocking, and reading its progress. No bpy here, so the
# tests run without Blender (plugin/blender/tests/test_command.py).

import json
import os
import queue
import shutil
import subprocess
import threading
import time


def find_radbake(preference, addon_dir):
    """The radbake executable: the preference when set, else `radbake` on PATH, else the build
    output of the repository the add-on was loaded from. None when there is none."""
    if preference:
        path = os.path.abspath(os.path.expanduser(preference))
        return path if os.path.isfile(path) and os.access(path, os.X_OK) else None
    on_path = shutil.which("radbake")
    if on_path:
        return on_path
    repo_build = os.path.normpath(os.path.join(addon_dir, "..", "..", "..", "build", "plugin", "cli", "radbake"))
    return repo_build if os.path.isfile(repo_build) and os.access(repo_build, os.X_OK) else None


def build_command(radbake, input_path, output_path, settings, lightmap_path=None):
    """The argument list for one bake. settings: a dict with method ('bilinear'|'constant'),
    refine ('SUBDIVIDE'|'MAX_EDGE'|'ADAPTIVE'), subdivide (int), max_edge (float), refine_target (float)
    and max_patches (int, 0: radbake's default) for ADAPTIVE, exposure_auto (bool),
    exposure (float EV), view (str), sky_enabled (bool), sky ((r, g, b)), lightmap_size (int)."""
    args = [radbake, "bake", input_path, "-o", output_path, "--progress", "json",
            "--method", settings["method"]]
    if settings["refine"] == "MAX_EDGE":
        args += ["--max-edge", repr(float(settings["max_edge"]))]
    elif settings["refine"] == "ADAPTIVE" and settings["method"] == "bilinear":
        # From one patch a face: refinement puts the patches where the light changes. (Constant
        # patches are shown flat and not refined: they take the subdivision below.)
        args += ["--refine", repr(float(settings["refine_target"]))]
        if int(settings.get("max_patches", 0)) > 0:
            args += ["--max-patches", str(int(settings["max_patches"]))]
    else:
        args += ["--subdivide", str(int(settings["subdivide"]))]
    if not settings["exposure_auto"]:
        args += ["--exposure", repr(float(settings["exposure"]))]
    if settings.get("view"):
        args += ["--view", settings["view"]]
    if settings["sky_enabled"]:
        args += ["--sky", ",".join(repr(float(c)) for c in settings["sky"])]
    if lightmap_path:
        args += ["--lightmap", lightmap_path, "--lightmap-size", str(int(settings["lightmap_size"]))]
    return args


def parse_progress(line):
    """(stage, fraction) from one `--progress json` line, or None for any other line."""
    line = line.strip()
    if not line.startswith("{"):
        return None
    try:
        data = json.loads(line)
    except ValueError:
        return None
    if not isinstance(data, dict) or "stage" not in data or "progress" not in data:
        return None
    try:
        fraction = min(max(float(data["progress"]), 0.0), 1.0)
    except (TypeError, ValueError):
        return None
    return str(data["stage"]), fraction


# The stages of a bake, in radbake's order, and their share of the whole, for one overall progress
# figure. A stage left out here would show as 0: the bar went back to nothing while the default
# bake refined (issue 16's room: 10 of its 80 s).
STAGES = (("import", 0.05), ("tessellate", 0.03), ("refine", 0.12), ("solve", 0.7), ("export", 0.1))


def overall_fraction(stage, fraction):
    """0..1 over the whole bake; 0 before radbake has named a stage."""
    done = 0.0
    for name, share in STAGES:
        if name == stage:
            return done + share * fraction
        done += share
    return 0.0


class BakeJob:
    """One radbake child process. Threads read its stdout and stderr into a queue, so whoever polls
    (Blender's modal timer) never blocks on a pipe. stderr is kept whole: it carries the error."""

    def __init__(self, args):
        self.args = args
        self.events = queue.Queue()
        self.stderr_lines = []
        self.stdout_lines = []
        self.stage, self.fraction = "starting", 0.0
        self.cancelled = False
        self.process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, bufsize=1)
        self._readers = [threading.Thread(target=self._read, args=(self.process.stdout, "out"), daemon=True),
                         threading.Thread(target=self._read, args=(self.process.stderr, "err"), daemon=True)]
        for reader in self._readers:
            reader.start()

    def _read(self, stream, name):
        for line in stream:
            self.events.put((name, line.rstrip("\n")))
        stream.close()

    def poll(self):
        """Takes in what the child printed; returns its exit code once it has ended and everything it
        printed has been read, else None."""
        self._drain()
        code = self.process.poll()
        if code is None:
            return None
        for reader in self._readers:
            reader.join(timeout=5)
        self._drain()
        return code

    def wait(self, on_progress=None):
        """Runs to the end (Blender in background mode has no event loop for a modal operator)."""
        while True:
            code = self.poll()
            if on_progress:
                on_progress(self.stage, self.fraction)
            if code is not None:
                return code
            time.sleep(0.05)

    def _drain(self):
        while True:
            try:
                name, line = self.events.get_nowait()
            except queue.Empty:
                return
            if name == "out":
                self.stdout_lines.append(line)
                continue
            progress = parse_progress(line)
            if progress:
                self.stage, self.fraction = progress
            elif line.strip():
                self.stderr_lines.append(line)

    def cancel(self):
        if self.process.poll() is None:
            self.cancelled = True
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()

    def error_message(self):
        """The CLI's own message: its `error:` lines, else everything it said on stderr."""
        errors = [l for l in self.stderr_lines if l.startswith("error:")]
        return "\n".join(errors or self.stderr_lines) or "radbake exited with code %s" % self.process.returncode

    def warnings(self):
        return [l for l in self.stderr_lines if l.startswith("warning:")]
