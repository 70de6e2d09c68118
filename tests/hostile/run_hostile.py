#!/usr/bin/env python3
"""Run radbake on every case of the hostile-input catalogue and check the error contract.

    python3 tests/hostile/run_hostile.py RADBAKE_BINARY WORKDIR [--only NAME...] [--timeout S]

Generates the catalogue (make_hostile.py) into WORKDIR/cases, runs the cases one after another
(each in its own process group, under RLIMIT_AS 4 GiB and a timeout), prints one line per case
and a summary, and exits 0 only if every case passes. See README.md for the contract.
"""
import argparse
import hashlib
import json
import os
import re
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ADDRESS_SPACE_LIMIT = 4 << 30      # bytes: a runaway case fails instead of eating the machine
RSS_LIMIT_KIB = 2 << 20            # peak resident set must stay below 2 GiB
MAX_ERROR_CHARS = 400
TEMP_NAME = re.compile(r"\.radbake-|\.tmp$")
OOM_TEXT = re.compile(r"out of memory|bad_alloc|cannot allocate memory", re.I)


def snapshot(root):
    """{relative path: description} of everything under root, symlinks not followed; regular files
    by sha256, FIFOs/devices/sockets/symlinks by kind (never opened)."""
    snap = {}
    if not os.path.lexists(root):
        return snap
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for name in dirnames + filenames:
            path = os.path.join(dirpath, name)
            rel = os.path.relpath(path, root)
            try:
                st = os.lstat(path)
            except FileNotFoundError:
                continue
            if stat.S_ISLNK(st.st_mode):
                snap[rel] = "symlink -> " + os.readlink(path)
            elif stat.S_ISDIR(st.st_mode):
                snap[rel] = "dir"
            elif stat.S_ISREG(st.st_mode):
                h = hashlib.sha256()
                with open(path, "rb") as f:
                    for block in iter(lambda: f.read(1 << 20), b""):
                        h.update(block)
                snap[rel] = "file %d %s" % (st.st_size, h.hexdigest())
            elif stat.S_ISFIFO(st.st_mode):
                snap[rel] = "fifo"
            else:
                snap[rel] = "special %o" % stat.S_IFMT(st.st_mode)
    return snap


def diff(before, after):
    """A short description of what changed between two snapshots, or ''."""
    created = sorted(set(after) - set(before))
    removed = sorted(set(before) - set(after))
    modified = sorted(k for k in set(before) & set(after) if before[k] != after[k])
    parts = []
    for label, names in (("created", created), ("removed", removed), ("modified", modified)):
        if names:
            parts.append("%s %s" % (label, ", ".join(names[:4]) + (" ..." if len(names) > 4 else "")))
    return "; ".join(parts)


def temporaries(*roots):
    found = []
    for root in roots:
        for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
            for name in dirnames + filenames:
                if TEMP_NAME.search(name):
                    found.append(os.path.relpath(os.path.join(dirpath, name), root))
    return found


NO_RLIMIT = os.environ.get("RADBAKE_HOSTILE_NO_RLIMIT", "") not in ("", "0")  # sanitizer builds


def limit_resources():
    if not NO_RLIMIT:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_LIMIT, ADDRESS_SPACE_LIMIT))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def run_process(argv, cwd, timeout, stdout_path, stderr_path):
    """Run argv in its own process group; returns (exit status as subprocess gives it, timed out,
    peak RSS in KiB, seconds). On timeout the whole group is killed."""
    t0 = time.monotonic()
    with open(stdout_path, "wb") as out, open(stderr_path, "wb") as err, open(os.devnull, "rb") as devnull:
        proc = subprocess.Popen(argv, cwd=cwd, stdin=devnull, stdout=out, stderr=err,
                                preexec_fn=limit_resources, start_new_session=True)
    timed_out = False
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid == proc.pid:
            break
        if time.monotonic() - t0 > timeout:
            timed_out = True
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            pid, status, usage = os.wait4(proc.pid, 0)
            break
        time.sleep(0.02)
    proc.returncode = os.waitstatus_to_exitcode(status)  # keep Popen from waiting again
    return proc.returncode, timed_out, usage.ru_maxrss, time.monotonic() - t0


def apply_setup(case, case_dir, out_dir):
    for action in case.get("setup", []):
        if "mkfifo" in action:
            path = os.path.join(case_dir, action["mkfifo"])
            if os.path.lexists(path):
                os.remove(path)
            os.mkfifo(path)
        elif "symlink" in action:
            link, target = action["symlink"]
            path = os.path.join(case_dir, link)
            if os.path.lexists(path):
                os.remove(path)
            os.symlink(target, path)
        elif "mkdir_out" in action:
            os.makedirs(os.path.join(out_dir, action["mkdir_out"]), exist_ok=True)
        else:
            raise ValueError("%s: unknown setup action %r" % (case["name"], action))


def expand(arg, case_dir, out_dir):
    return arg.replace("{case}", case_dir).replace("{out}", out_dir)


def wants_quiet(case):
    if "quiet" in case:
        return bool(case["quiet"])
    # -q prints errors only: keep the warnings when the case expects one
    return case["args"][:1] == ["bake"] and not (case["expect_exit"] == 0 and case.get("expect"))


def check(case, code, timed_out, rss_kib, stdout, stderr, case_dir, out_dir, before_case, before_out):
    """Returns the list of failures (empty: pass)."""
    fails = []
    if timed_out:
        return ["timeout"]
    if code < 0:
        fails.append("killed by signal %d (%s)" % (-code, signal.Signals(-code).name if -code in
                                                   signal.valid_signals() else "?"))
    elif code > 128:
        fails.append("exit %d looks like a signal" % code)
    if code != case["expect_exit"]:
        fails.append("exit %d, expected %d" % (code, case["expect_exit"]))
    if OOM_TEXT.search(stderr):
        fails.append("ran out of memory (the %d GiB address-space limit)" % (ADDRESS_SPACE_LIMIT >> 30))
    if rss_kib >= RSS_LIMIT_KIB:
        fails.append("peak RSS %.0f MiB >= 2 GiB" % (rss_kib / 1024))
    expect = case.get("expect")
    if code != 0:
        text = stderr[:-1] if stderr.endswith("\n") else stderr
        if "\n" in text or "\r" in text or not text:
            n = len(stderr.splitlines())
            fails.append("stderr is %d lines, not one: %r" % (n, stderr[:300]))
        else:
            if not text.startswith("error: "):
                fails.append("error line does not start with 'error: ': %r" % text[:200])
            if len(text) > MAX_ERROR_CHARS:
                fails.append("error line is %d characters (> %d)" % (len(text), MAX_ERROR_CHARS))
            if re.search(r"[\x00-\x08\x0b-\x1f\x7f]", text):
                fails.append("error line holds control characters")
            if expect and not re.search(expect, text):
                fails.append("error line does not match /%s/: %r" % (expect, text[:300]))
        if stdout:
            fails.append("stdout not empty: %r" % stdout[:200])
        changed = diff(before_out, snapshot(out_dir))
        if changed:
            fails.append("output folder changed: " + changed)
    else:
        lines = stderr.splitlines()
        bad = [l for l in lines if not l.startswith("warning: ")]
        if bad:
            fails.append("stderr line not a warning: %r" % bad[0][:200])
        long_lines = [l for l in lines if len(l) > len("warning: ") + 400]
        if long_lines:
            fails.append("warning longer than 400 characters: %d" % len(long_lines[0]))
        if expect and not any(re.search(expect, l) for l in lines):
            fails.append("no warning matches /%s/ (stderr %r)" % (expect, stderr[:300]))
        for rel in case.get("outputs", []):
            if not os.path.isfile(os.path.join(out_dir, rel)):
                fails.append("missing output " + rel)
        for rel, pattern in case.get("output_match", {}).items():
            path = os.path.join(out_dir, rel)
            if os.path.isfile(path):
                with open(path, "r", errors="replace") as f:
                    content = f.read(1 << 20)
                if not re.fullmatch(pattern, content):
                    fails.append("%s does not match /%s/: %r" % (rel, pattern, content[:120]))
    changed = diff(before_case, snapshot(case_dir))
    if changed:
        fails.append("case folder (input) changed: " + changed)
    left = temporaries(case_dir, out_dir)
    if left:
        fails.append("temporaries left: " + ", ".join(left[:4]))
    return fails


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1].strip())
    ap.add_argument("radbake")
    ap.add_argument("workdir")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run only these cases (regular expressions, full match)")
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per case (default 120)")
    a = ap.parse_args()

    radbake = os.path.abspath(a.radbake)
    work = os.path.abspath(a.workdir)
    cases_dir = os.path.join(work, "cases")
    outs_dir = os.path.join(work, "out")
    logs_dir = os.path.join(work, "logs")
    os.makedirs(work, exist_ok=True)
    for d in (outs_dir, logs_dir):
        if os.path.isdir(d):
            shutil.rmtree(d)
        os.makedirs(d)
    subprocess.run([sys.executable, os.path.join(HERE, "make_hostile.py"), cases_dir], check=True,
                   stdout=subprocess.DEVNULL)
    with open(os.path.join(cases_dir, "cases.json")) as f:
        cases = json.load(f)
    if a.only:
        cases = [c for c in cases if any(re.fullmatch(p, c["name"]) for p in a.only)]
        if not cases:
            sys.exit("run_hostile.py: no case matches --only %s" % " ".join(a.only))

    failed = []
    t_all = time.monotonic()
    for case in cases:
        name = case["name"]
        case_dir = os.path.join(cases_dir, name)
        out_dir = os.path.join(outs_dir, name)
        os.makedirs(out_dir)
        apply_setup(case, case_dir, out_dir)
        cwd = case.get("cwd")
        cwd = out_dir if cwd == "out" else case_dir if cwd in (None, "case") else os.path.join(case_dir, cwd)
        argv = [radbake] + [expand(x, case_dir, out_dir) for x in case["args"]]
        if wants_quiet(case):
            argv.append("-q")
        before_case, before_out = snapshot(case_dir), snapshot(out_dir)
        so, se = os.path.join(logs_dir, name + ".stdout"), os.path.join(logs_dir, name + ".stderr")
        code, timed_out, rss, secs = run_process(argv, cwd, a.timeout, so, se)
        with open(so, "rb") as f:
            stdout = f.read().decode("utf-8", "replace")
        with open(se, "rb") as f:
            stderr = f.read().decode("utf-8", "replace")
        fails = check(case, code, timed_out, rss, stdout, stderr, case_dir, out_dir, before_case, before_out)
        status = "FAIL" if fails else "PASS"
        reason = ": " + "; ".join(fails) if fails else ""
        print("%s %s%s (exit %s, %.0f MiB, %.1f s)" % (status, name, reason, "timeout" if timed_out else code,
                                                      rss / 1024, secs), flush=True)
        if fails:
            failed.append(name)
    total = time.monotonic() - t_all
    print("hostile catalogue: %d passed, %d failed of %d (%.0f s)%s" %
          (len(cases) - len(failed), len(failed), len(cases), total,
           "\nfailed: " + " ".join(failed) if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
