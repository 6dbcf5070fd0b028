#!/usr/bin/env python3
"""What a power cut could undo (docs/state.md): a SIGKILL shows the order of renames, not what a
power cut loses from the page cache. This runs the fault tests' writer (glint_state_writer) with
tests/faults' syscall_log.so preloaded and checks, from the calls it logged, the order the state
store's guarantee rests on, for every save of every item:

- before an item's link is renamed into place: every file of the new generation, the generation
  directory and the generations' directory have been fsynced since their last change;
- after it, the state directory is fsynced before the old generation is removed, before the next
  save of any item and before the program ends;
- every temporary file (core/atomic_file: the capture's maps) is fsynced before it is renamed,
  and its directory after.

usage: check_sync_order.py WRITER SYSCALL_LOG_SO WORK_DIR [ROUNDS]
"""
import os
import re
import shutil
import subprocess
import sys

writer, shim, work = sys.argv[1:4]
rounds = sys.argv[4] if len(sys.argv) > 4 else "3"
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
state = os.path.join(os.path.realpath(work), "state")
log = os.path.join(work, "calls.log")
env = dict(os.environ, LD_PRELOAD=os.path.realpath(shim), GLINT_SYSCALL_LOG=log)
# Under AddressSanitizer the preloaded shim comes before ASan's runtime, which ASan refuses unless told.
env["ASAN_OPTIONS"] = ":".join(filter(None, [os.environ.get("ASAN_OPTIONS"), "verify_asan_link_order=0"]))
subprocess.run([writer, state, rounds, "1"], env=env, check=True, stdout=subprocess.DEVNULL)
events = [line.rstrip("\n").split("\t") for line in open(log)]
if not events:
    sys.exit("FAIL the writer logged no calls: is " + shim + " preloaded?")

last_change = {}  # path -> index of the last event that changed it (created, renamed into, an entry of a directory)
last_sync = {}    # path -> index of its last fsync
entries = {}      # directory -> set of names in it (as far as logged)
problems = []
checked = {}      # item -> saves checked
temps = 0
pending = {}      # directory -> (index, why) that needs an fsync of it


def changed(path, i):
    last_change[path] = i
    parent = os.path.dirname(path)
    last_change[parent] = i
    entries.setdefault(parent, set()).add(os.path.basename(path))


def removed(path, i):
    parent = os.path.dirname(path)
    last_change[parent] = i
    entries.get(parent, set()).discard(os.path.basename(path))


def durable(path):
    return last_sync.get(path, -1) > last_change.get(path, -1)


def need_synced(path, i, why):
    if not durable(path):
        problems.append(f"call {i}: {why}: {path} not fsynced since its last change (call {last_change.get(path)})")


link_re = re.compile(r"^\.(.+)\.link-\d+$")
symlinks = {}
for i, e in enumerate(events):
    verb, a = e[0], e[1]
    b = e[2] if len(e) > 2 else None
    if verb == "fsync":
        last_sync[a] = i
        pending.pop(a, None)
    elif verb in ("create", "mkdir"):
        changed(a, i)
    elif verb == "symlink":
        symlinks[a] = b
        changed(a, i)
    elif verb == "unlink":
        for d, (j, why) in list(pending.items()):
            if a.startswith(os.path.join(d, "")) and ".gen/" in a:
                problems.append(f"call {i}: {a} removed before {d} was fsynced after {why} (call {j})")
                pending.pop(d)
        removed(a, i)
    elif verb == "rename":
        m = link_re.match(os.path.basename(a))
        if m and os.path.dirname(a) == state and b == os.path.join(state, m.group(1)):
            item = m.group(1)
            for d, (j, why) in list(pending.items()):
                if d == state:
                    problems.append(f"call {i}: {item}'s link renamed before {d} was fsynced after {why} (call {j})")
                    pending.pop(d)
            target = symlinks.get(a)
            parts = target.split("/") if target else []
            if len(parts) < 2:
                problems.append(f"call {i}: {item}'s link {a} points at {target}")
            else:
                gen_root = os.path.join(state, parts[0])
                gen_dir = os.path.join(gen_root, parts[1])
                for name in sorted(entries.get(gen_dir, ())):
                    need_synced(os.path.join(gen_dir, name), i, f"{item}'s link renamed")
                need_synced(gen_dir, i, f"{item}'s link renamed")
                need_synced(gen_root, i, f"{item}'s link renamed")
                if "MANIFEST.json" not in entries.get(gen_dir, ()):
                    problems.append(f"call {i}: {item}'s generation {gen_dir} has no manifest when linked")
            checked[item] = checked.get(item, 0) + 1
            pending[state] = (i, f"{item}'s link rename")
        elif ".tmp-" in os.path.basename(a):
            temps += 1
            need_synced(a, i, "a temporary file renamed")
            pending[os.path.dirname(b)] = (i, f"the rename of {os.path.basename(a)}")
        else:
            for d, (j, why) in list(pending.items()):
                if os.path.dirname(a) == d:
                    problems.append(f"call {i}: {a} moved on before {d} was fsynced after {why} (call {j})")
                    pending.pop(d)
        removed(a, i)
        changed(b, i)
        if a in last_sync and b is not None:
            last_sync[b] = last_sync[a]  # the same inode, synced under its old name
for d, (j, why) in pending.items():
    problems.append(f"end: {d} never fsynced after {why} (call {j})")

print(f"{len(events)} calls logged; saves checked: " + ", ".join(f"{k} {v}" for k, v in sorted(checked.items())) +
      f"; {temps} temporary files renamed")
want = {"scene", "calibration.json", "settings.toml", "pin-lock.json"}
if not want <= set(checked) or min(checked.values()) < int(rounds):
    problems.append(f"not every item's saves were seen: {checked}")
if temps < 2 * int(rounds):
    problems.append(f"only {temps} temporary files renamed (the capture's two maps a round)")
for p in problems[:20]:
    print("FAIL " + p)
print("ok   every link, file and directory synced in order" if not problems else f"{len(problems)} problems")
sys.exit(1 if problems else 0)
