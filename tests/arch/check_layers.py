#!/usr/bin/env python3
"""Checks that Glint's modules depend on each other only the way the layering allows.

Two kinds of edges are checked, both in appliance/ and firmware_bridge/ (tests/ is out of scope):
  - every `#include "..."` (and `#include <appliance/...>`, `<firmware_bridge/...>`) of a
    .cpp/.hpp/.h/.cc file, both ends mapped to their modules;
  - every target named in `target_link_libraries` of a CMakeLists.txt, targets mapped to the
    module of the folder whose CMakeLists.txt defines them.

Every edge against the rules is printed as one line `file:line: A -> B (rule: ...) [what]`.

Usage: check_layers.py [--root REPO] [--self-test]
Exit status: 0 no violations (or the self-test passed), 1 violations (or the self-test failed),
2 bad usage.
"""

import argparse
import os
import posixpath
import re
import shutil
import sys
import tempfile

# ---------------------------------------------------------------------------------------------
# The rules. A module may always use itself; otherwise only what its row lists.
#
#   appliance:  app -> ui -> {render, tracking, sim, capture, convolution} -> {gl, core}, gl -> core
#   firmware_bridge:  firmware/sim -> host -> {firmware, recording} -> protocol
#
# "M (public headers)" allows #include of M's public headers only: the headers directly in M's
# folder, not in a subfolder. Linking M's library is allowed either way.
# ---------------------------------------------------------------------------------------------
HOST_PUBLIC = "firmware_bridge/host (public headers)"

RULES = {
    # --- appliance, bottom up --------------------------------------------------------------
    "core":        [],
    "gl":          ["core"],
    # convolution/gpu is part of convolution; only it may use gl (PART_RULES below).
    "convolution": ["core", "gl"],
    # The capture pipeline reads orientations through the host drivers' interface; the sensor
    # firmware, the wire format and the recording format are none of its business.
    "capture":     ["core", "gl", HOST_PUBLIC],
    "tracking":    ["core", "gl"],
    # The renderer shades with the maps the convolution makes.
    "render":      ["core", "gl", "convolution"],
    # The simulator implements capture's camera source and drives the sensor firmware's host
    # build, so it sees all of firmware_bridge; it draws tracking's board on the kiosk's table
    # (sim/kiosk_simulator.hpp), so the board's geometry and print have one definition.
    "sim":         ["core", "gl", "capture", "tracking",
                    "firmware_bridge/host", "firmware_bridge/recording", "firmware_bridge/protocol",
                    "firmware_bridge/firmware", "firmware_bridge/firmware/sim"],
    "ui":          ["core", "gl", "convolution", "capture", "tracking", "render", "sim"],
    "app":         ["core", "gl", "convolution", "capture", "tracking", "render", "sim", "ui",
                    "firmware_bridge/host", "firmware_bridge/recording"],

    # --- firmware_bridge, bottom up (nothing here may use the appliance) --------------------
    # The wire format: freestanding, shared by both ends of the link.
    "firmware_bridge/protocol":     [],
    # The portable board firmware: no OS, so nothing host-side.
    "firmware_bridge/firmware":     ["firmware_bridge/protocol"],
    # The synthetic-session generator (glint-recording generate) rotates with the firmware's
    # freestanding maths (firmware/rotation.hpp, header only) rather than a copy of its own.
    "firmware_bridge/recording":    ["firmware_bridge/protocol", "firmware_bridge/firmware (public headers)"],
    # The appliance-side drivers reuse the firmware's maths, HAL interfaces and BNO055 driver,
    # and record what they receive.
    "firmware_bridge/host":         ["firmware_bridge/protocol", "firmware_bridge/firmware",
                                     "firmware_bridge/recording"],
    # The firmware built for the host (a simulated board on a pseudo-terminal): shares the
    # termios speed table with the serial driver (host/serial_speed.hpp, header only).
    "firmware_bridge/firmware/sim": ["firmware_bridge/firmware", "firmware_bridge/protocol",
                                     "firmware_bridge/host"],
}

# Parts of a module held to less than the module: (folder, except this subfolder, modules the
# part may not use, why).
PART_RULES = [
    ("appliance/convolution", "appliance/convolution/gpu", ["gl"],
     "only convolution/gpu may use gl: the CPU engine builds and tests without a GPU"),
]

# Folders that are their own module although they sit inside another module's folder.
SUBMODULES = {
    "firmware_bridge/firmware/sim": "firmware_bridge/firmware/sim",
}

SCANNED = ("appliance", "firmware_bridge")
SOURCE_EXTENSIONS = (".cpp", ".hpp", ".h", ".cc")
PUBLIC_SUFFIX = " (public headers)"


# --- modules -------------------------------------------------------------------------------------

def module_of(rel):
    """Module of a repository-relative path (posix), or None outside the scanned folders."""
    for folder in sorted(SUBMODULES, key=len, reverse=True):
        if rel == folder or rel.startswith(folder + "/"):
            return SUBMODULES[folder]
    parts = rel.split("/")
    if parts[0] not in SCANNED:
        return None
    if len(parts) < 3:  # a file directly in appliance/ or firmware_bridge/
        return parts[0]
    return parts[1] if parts[0] == "appliance" else "firmware_bridge/" + parts[1]


def folder_of(module):
    if module in SUBMODULES.values() or module.startswith("firmware_bridge/"):
        return module
    return "appliance/" + module


def is_public_header(rel, module):
    return (posixpath.dirname(rel) == folder_of(module)
            and rel.endswith((".hpp", ".h")))


def allowed_modules(module):
    return [a[:-len(PUBLIC_SUFFIX)] if a.endswith(PUBLIC_SUFFIX) else a for a in RULES[module]]


def reaches(start, goal):
    """True if `start` may depend on `goal` through any chain of allowed edges."""
    seen, stack = set(), [start]
    while stack:
        m = stack.pop()
        if m == goal:
            return True
        if m in seen or m not in RULES:
            continue
        seen.add(m)
        stack.extend(allowed_modules(m))
    return False


def judge(src_module, dst_module, src_rel, dst_rel):
    """None if the edge is allowed, else the rule it breaks. dst_rel is None for a link edge."""
    if src_module == dst_module:
        return None
    for m in (src_module, dst_module):
        if m not in RULES:
            return "module %s is not in the rule table of tests/arch/check_layers.py" % m
    for folder, exception, forbidden, why in PART_RULES:
        inside = src_rel == folder or src_rel.startswith(folder + "/")
        excepted = src_rel == exception or src_rel.startswith(exception + "/")
        if inside and not excepted and dst_module in forbidden:
            return why
    allowed = RULES[src_module]
    if dst_module in allowed:
        return None
    if dst_module + PUBLIC_SUFFIX in allowed:
        if dst_rel is None or is_public_header(dst_rel, dst_module):
            return None
        return "%s may use %s only through its public headers, %s/*.hpp" % (
            src_module, dst_module, folder_of(dst_module))
    may = ", ".join(allowed) if allowed else "nothing"
    direction = "upward; " if reaches(dst_module, src_module) else ""
    return "%s%s may use %s" % (direction, src_module, may)


# --- walking the tree ----------------------------------------------------------------------------

def walk(root):
    """Repository-relative paths of the source files and CMakeLists.txt files to check.

    Build trees (a CMakeCache.txt or CMakeFiles inside) and hidden folders are skipped: their
    generated files are not the project's sources.
    """
    sources, cmakes = [], []
    for top in SCANNED:
        base = os.path.join(root, top)
        for dirpath, dirnames, filenames in os.walk(base):
            if "CMakeCache.txt" in filenames:
                dirnames[:] = []
                continue
            dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and d != "CMakeFiles")
            rel_dir = os.path.relpath(dirpath, root).replace(os.sep, "/")
            for name in sorted(filenames):
                rel = rel_dir + "/" + name
                if name.endswith(SOURCE_EXTENSIONS):
                    sources.append(rel)
                elif name == "CMakeLists.txt":
                    cmakes.append(rel)
    return sources, cmakes


# --- C++ includes --------------------------------------------------------------------------------

def raw_prefix_ok(text, i):
    """True if the R at i starts a raw string literal: R"..., u8R"..., uR"..., UR"..., LR"..."""
    j = i
    while j > 0 and (text[j - 1].isalnum() or text[j - 1] == "_"):
        j -= 1
    return text[j:i] in ("", "u8", "u", "U", "L")


def blank_comments(text):
    """The text with comments and raw string literals blanked; lines and ordinary strings kept.

    A commented-out include, or an #include line inside a raw string (a shader embedded in the
    source), is not a dependency.
    """
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        two = text[i:i + 2]
        if two == "//":
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif two == "/*":
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text[i + 1:i + 2] == '"' and raw_prefix_ok(text, i):
            m = re.match(r'R"([^()\\\s]{0,16})\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i + m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            # A quote after a digit is a digit separator (1'000), not a character literal.
            if c == "'" and i > 0 and text[i - 1].isalnum():
                out.append(c)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(text[i:j])
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


INCLUDE_RE = re.compile(r'^\s*#\s*include\s*(?:"([^"]+)"|<((?:%s)/[^>]+)>)' % "|".join(SCANNED))
CONDITIONAL_RE = re.compile(r"^\s*#\s*(if|ifdef|ifndef|elif|else|endif)\b(.*)$")


def includes(text):
    """(line, path, quoted) of every live #include; `#if 0` blocks are dead."""
    found = []
    dead_depth = 0  # > 0 inside an `#if 0` block: the depth of nested conditionals in it
    for number, line in enumerate(blank_comments(text).split("\n"), start=1):
        cond = CONDITIONAL_RE.match(line)
        if cond:
            word, rest = cond.group(1), cond.group(2).strip()
            if dead_depth:
                if word in ("if", "ifdef", "ifndef"):
                    dead_depth += 1
                elif word == "endif":
                    dead_depth -= 1
                elif word in ("else", "elif") and dead_depth == 1:
                    dead_depth = 0
            elif word == "if" and rest == "0":
                dead_depth = 1
            continue
        if dead_depth:
            continue
        m = INCLUDE_RE.match(line)
        if m:
            found.append((number, m.group(1) or m.group(2), m.group(1) is not None))
    return found


def resolve(root, src_rel, spelled, quoted):
    """Repository-relative path an include means, or None for a system or third-party header.

    A quoted include is looked up next to the including file first, then from the repository
    root (the include path every target sets), as the compiler does.
    """
    candidates = []
    if quoted:
        candidates.append(posixpath.normpath(posixpath.join(posixpath.dirname(src_rel), spelled)))
    candidates.append(posixpath.normpath(spelled))
    for c in candidates:
        if not c.startswith("../") and os.path.isfile(os.path.join(root, c)):
            return c
    # Not on disk (generated, or a module still being written): spelled from the root, the
    # path still names its module.
    spelled = posixpath.normpath(spelled)
    return spelled if spelled.split("/")[0] in SCANNED else None


# --- CMake ---------------------------------------------------------------------------------------

CMAKE_TOKEN_RE = re.compile(r"""
    (?P<space>\s+)
  | (?P<comment>\#\[(?P<ceq>=*)\[.*?\](?P=ceq)\]|\#[^\n]*)
  | (?P<quoted>"(?:\\.|[^"\\])*")
  | (?P<bracket>\[(?P<beq>=*)\[.*?\](?P=beq)\])
  | (?P<open>\()
  | (?P<close>\))
  | (?P<word>[^\s()"\#]+)
""", re.VERBOSE | re.DOTALL)


def cmake_commands(text):
    """(name, [(argument, line)]) of every command invocation; comments dropped."""
    tokens = []
    line = 1
    for m in CMAKE_TOKEN_RE.finditer(text):
        kind = next(k for k in ("space", "comment", "quoted", "bracket", "open", "close", "word")
                    if m.group(k) is not None)
        if kind not in ("space", "comment"):
            value = m.group(kind)
            if kind == "quoted":
                value = value[1:-1]
            tokens.append((kind, value, line))
        line += m.group(0).count("\n")
    commands = []
    i = 0
    while i < len(tokens):
        kind, value, _ = tokens[i]
        if kind == "word" and i + 1 < len(tokens) and tokens[i + 1][0] == "open":
            depth, args, j = 1, [], i + 2
            while j < len(tokens) and depth:
                k, v, ln = tokens[j]
                if k == "open":
                    depth += 1
                elif k == "close":
                    depth -= 1
                else:
                    args.append((v, ln))
                j += 1
            commands.append((value.lower(), args))
            i = j
        else:
            i += 1
    return commands


LINK_KEYWORDS = {"PUBLIC", "PRIVATE", "INTERFACE", "LINK_PUBLIC", "LINK_PRIVATE",
                 "LINK_INTERFACE_LIBRARIES", "debug", "optimized", "general"}


def link_items(argument):
    """Names an argument of target_link_libraries may denote (lists and generator expressions
    split apart; ${variables} are not targets of ours)."""
    names = []
    for item in argument.split(";"):
        if "$<" in item:
            item = re.sub(r"\$\{[^}]*\}", " ", item)
            names.extend(p for p in re.split(r"[$<>:,\s]+", item) if p)
        elif item and "${" not in item:
            names.append(item)
    return names


def cmake_targets(root, cmakes):
    """target -> CMakeLists.txt that defines it (aliases point at their target's file)."""
    targets, aliases = {}, {}
    for rel in cmakes:
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
            commands = cmake_commands(f.read())
        for name, args in commands:
            if name not in ("add_library", "add_executable") or not args:
                continue
            words = [a for a, _ in args]
            if len(words) >= 3 and words[1] == "ALIAS":
                aliases[words[0]] = words[2]
            elif "IMPORTED" not in words[1:]:  # an imported target stands for an outside library
                targets[words[0]] = rel
    for alias, target in aliases.items():
        if target in targets:
            targets[alias] = targets[target]
    return targets


# --- the check -----------------------------------------------------------------------------------

def check(root):
    """Sorted list of (file, line, message) for every edge against the rules."""
    sources, cmakes = walk(root)
    violations = []
    for rel in sources:
        src_module = module_of(rel)
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
            text = f.read()
        for line, spelled, quoted in includes(text):
            dst_rel = resolve(root, rel, spelled, quoted)
            if dst_rel is None:
                continue
            dst_module = module_of(dst_rel)
            if dst_module is None:
                continue
            rule = judge(src_module, dst_module, rel, dst_rel)
            if rule:
                violations.append((rel, line, "%s -> %s (rule: %s) [%s]" % (
                    src_module, dst_module, rule, spelled)))
    targets = cmake_targets(root, cmakes)
    for rel in cmakes:
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
            commands = cmake_commands(f.read())
        for name, args in commands:
            if name != "target_link_libraries" or not args:
                continue
            target = args[0][0]
            # The edge belongs to the module that defines the target, wherever it is linked.
            owner = targets.get(target, rel)
            src_module = module_of(owner)
            for argument, line in args[1:]:
                if argument in LINK_KEYWORDS:
                    continue
                for item in link_items(argument):
                    if item not in targets:
                        continue
                    dst_module = module_of(targets[item])
                    rule = judge(src_module, dst_module, owner, None)
                    if rule:
                        violations.append((rel, line, "%s -> %s (rule: %s) [%s links %s]" % (
                            src_module, dst_module, rule, target, item)))
    return sorted(set(violations), key=lambda v: (v[0], v[1], v[2]))


def format_violation(v):
    return "%s:%d: %s" % v


# --- self-test -----------------------------------------------------------------------------------

def check_rule_table():
    """The table itself must be sane: known modules only, and no cycle."""
    problems = []
    for module in RULES:
        for dep in allowed_modules(module):
            if dep not in RULES:
                problems.append("%s lists unknown module %s" % (module, dep))
            elif dep == module:
                problems.append("%s lists itself" % module)
            elif reaches(dep, module):
                problems.append("cycle: %s and %s may use each other" % (module, dep))
    return problems


# A tree with one of each case: the line numbers of the expected violations are part of it.
SYNTHETIC = {
    "appliance/core/CMakeLists.txt":
        "add_library(glint_core STATIC a.cpp bad.cpp)\n"
        "target_link_libraries(glint_core PUBLIC Threads::Threads PRIVATE glint_warnings)\n",
    "appliance/core/a.hpp": "#pragma once\n",
    "appliance/core/a.cpp":
        '#include "a.hpp"\n'                                  # next to the file: core itself
        "#include <vector>\n"
        '#include "imgui.h"\n'                                # third-party: not ours
        '// #include "appliance/capture/x.hpp"\n'
        "/*\n"
        '#include "appliance/capture/x.hpp"\n'
        "*/\n"
        "#if 0\n"
        '#include "appliance/capture/x.hpp"\n'
        "#endif\n"
        'const char* s = u8R"glsl(\n'
        '#include "appliance/capture/x.hpp"\n'
        ')glsl";\n'
        "int n = 1'000;\n"
        '#include "appliance/core/a.hpp"\n',
    "appliance/core/bad.cpp":
        "// A wrong include: core must not know capture.\n"
        '#include "appliance/capture/x.hpp"\n',               # VIOLATION line 2
    "appliance/gl/CMakeLists.txt":
        "add_library(glint_gl STATIC g.cpp)\n"
        "target_link_libraries(glint_gl PUBLIC glint_core)\n",
    "appliance/gl/g.hpp": '#include "appliance/core/a.hpp"\n',
    "appliance/convolution/CMakeLists.txt":
        "# target_link_libraries(glint_convolution glint_capture)\n"
        "add_library(glint_convolution STATIC c.cpp)\n"
        "target_link_libraries(glint_convolution PUBLIC glint_core\n"
        "  glint_gl)\n",                                      # VIOLATION line 4 (part rule)
    "appliance/convolution/c.hpp": "#pragma once\n",
    "appliance/convolution/c.cpp":
        '#include "appliance/core/a.hpp"\n'
        '#include "appliance/gl/g.hpp"\n',                    # VIOLATION line 2 (part rule)
    "appliance/convolution/gpu/CMakeLists.txt":
        "add_library(glint_convolution_gpu STATIC e.cpp)\n"
        "target_link_libraries(glint_convolution_gpu PUBLIC glint_convolution glint_gl)\n",
    "appliance/convolution/gpu/e.cpp":
        '#include "../c.hpp"\n'
        '#include "appliance/gl/g.hpp"\n',
    "appliance/capture/CMakeLists.txt":
        "add_library(glint_capture STATIC x.cpp)\n"
        "target_link_libraries(glint_capture PUBLIC glint_core glint_bridge_host ${OpenCV_LIBS}\n"
        "  glint_bridge_recording\n"                          # VIOLATION line 3
        "  PRIVATE $<$<BOOL:${X}>:glint_gl>)\n",
    "appliance/capture/x.hpp":
        '#include "firmware_bridge/host/source.hpp"\n'
        '#include "firmware_bridge/host/detail/impl.hpp"\n'   # VIOLATION line 2 (not public)
        '#include "firmware_bridge/firmware/rotation.hpp"\n'  # VIOLATION line 3
        "#include <firmware_bridge/recording/clock.hpp>\n",   # VIOLATION line 4
    "appliance/render/r.cpp":
        '#include "appliance/convolution/c.hpp"\n'
        '#include "appliance/capture/x.hpp"\n',               # VIOLATION line 2 (sideways)
    "appliance/sim/s.cpp":
        '#include "appliance/capture/x.hpp"\n'
        '#include "firmware_bridge/firmware/sim/board.hpp"\n'
        '#include "firmware_bridge/protocol/p.hpp"\n'
        '#include "appliance/tracking/board.hpp"\n',      # the kiosk's board: allowed
    "appliance/tracking/t.cpp":
        '#include "appliance/core/a.hpp"\n'
        '#include "appliance/sim/s.hpp"\n',               # VIOLATION line 2 (the edge is one way)
    "appliance/ui/u.cpp":
        '#include "appliance/sim/s.hpp"\n'
        '#include "firmware_bridge/host/source.hpp"\n',       # VIOLATION line 2
    "appliance/app/main.cpp":
        '#include "appliance/ui/not_written_yet.hpp"\n'
        '#include "firmware_bridge/protocol/p.hpp"\n',        # VIOLATION line 2
    "appliance/widgets/w.cpp":
        '#include "appliance/core/a.hpp"\n',                  # VIOLATION line 1 (unknown module)
    "appliance/build-here/CMakeCache.txt": "",
    "appliance/build-here/generated.cpp": '#include "appliance/app/main.cpp"\n',
    "firmware_bridge/protocol/CMakeLists.txt": "add_library(glint_bridge_protocol STATIC p.cpp)\n",
    "firmware_bridge/protocol/p.hpp": "#pragma once\n",
    "firmware_bridge/firmware/CMakeLists.txt":
        "add_library(glint_bridge_firmware STATIC rotation.cpp)\n"
        "target_link_libraries(glint_bridge_firmware PUBLIC glint_bridge_protocol)\n"
        "add_subdirectory(sim)\n",
    "firmware_bridge/firmware/rotation.hpp":
        '#include "firmware_bridge/protocol/p.hpp"\n'
        '#include "firmware_bridge/host/source.hpp"\n',       # VIOLATION line 2
    "firmware_bridge/firmware/sim/CMakeLists.txt":
        "add_library(glint_bridge_firmware_sim STATIC board.cpp)\n"
        "target_link_libraries(glint_bridge_firmware_sim PUBLIC glint_bridge_firmware util)\n",
    "firmware_bridge/firmware/sim/board.hpp":
        '#include "firmware_bridge/firmware/rotation.hpp"\n'
        '#include "firmware_bridge/host/source.hpp"\n'
        '#include "appliance/core/a.hpp"\n',                  # VIOLATION line 3
    "firmware_bridge/recording/CMakeLists.txt":
        "add_library(glint_bridge_recording STATIC clock.cpp)\n"
        "target_link_libraries(glint_bridge_recording PUBLIC glint_bridge_protocol)\n",
    "firmware_bridge/recording/clock.hpp": "#pragma once\n",
    "firmware_bridge/host/CMakeLists.txt":
        "add_library(glint_bridge_host STATIC source.cpp)\n"
        "target_link_libraries(glint_bridge_host PUBLIC glint_bridge_protocol glint_bridge_recording\n"
        "  glint_bridge_firmware)\n",
    "firmware_bridge/host/source.hpp": '#include "firmware_bridge/recording/clock.hpp"\n',
    "firmware_bridge/host/detail/impl.hpp": '#include "firmware_bridge/host/source.hpp"\n',
}

EXPECTED = [
    ("appliance/app/main.cpp", 2, "app -> firmware_bridge/protocol"),
    ("appliance/capture/CMakeLists.txt", 3, "capture -> firmware_bridge/recording"),
    ("appliance/capture/x.hpp", 2, "capture -> firmware_bridge/host"),
    ("appliance/capture/x.hpp", 3, "capture -> firmware_bridge/firmware"),
    ("appliance/capture/x.hpp", 4, "capture -> firmware_bridge/recording"),
    ("appliance/convolution/CMakeLists.txt", 4, "convolution -> gl"),
    ("appliance/convolution/c.cpp", 2, "convolution -> gl"),
    ("appliance/core/bad.cpp", 2, "core -> capture (rule: upward;"),
    ("appliance/render/r.cpp", 2, "render -> capture"),
    ("appliance/tracking/t.cpp", 2, "tracking -> sim (rule: upward;"),
    ("appliance/ui/u.cpp", 2, "ui -> firmware_bridge/host"),
    ("appliance/widgets/w.cpp", 1, "widgets -> core (rule: module widgets is not in the rule table"),
    ("firmware_bridge/firmware/rotation.hpp", 2, "firmware_bridge/firmware -> firmware_bridge/host"),
    ("firmware_bridge/firmware/sim/board.hpp", 3, "firmware_bridge/firmware/sim -> core"),
]


def write_tree(base, files):
    for rel, text in files.items():
        path = os.path.join(base, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)


def mutation_test(root, failures):
    """A copy of the real tree with one wrong include added must report exactly that include
    on top of what the real tree reports."""
    with tempfile.TemporaryDirectory(prefix="glint-arch-") as tmp:
        for top in SCANNED:
            if os.path.isdir(os.path.join(root, top)):
                shutil.copytree(os.path.join(root, top), os.path.join(tmp, top),
                                ignore=shutil.ignore_patterns("CMakeFiles", ".*"))
        before = check(tmp)
        core_dir = os.path.join(tmp, "appliance", "core")
        victims = []
        if os.path.isdir(core_dir):
            victims = sorted(f for f in os.listdir(core_dir) if f.endswith(".cpp"))
        if not victims:
            failures.append("mutation: no appliance/core/*.cpp in %s to break" % root)
            return
        victim = "appliance/core/" + victims[0]
        # A header of a module above core: the app's, spelled from the root like every include.
        wrong = '#include "appliance/app/commands.hpp"  // deliberately wrong: core -> app\n'
        with open(os.path.join(tmp, victim), encoding="utf-8") as f:
            text = f.read()
        with open(os.path.join(tmp, victim), "w", encoding="utf-8") as f:
            f.write(wrong + text)
        after = check(tmp)
        shifted = [(f, ln + 1 if f == victim else ln, m) for f, ln, m in before]
        new = [v for v in after if v not in shifted]
        expected = [(victim, 1)]
        if [(f, ln) for f, ln, _ in new] != expected or "core -> app (rule: upward;" not in new[0][2]:
            failures.append("mutation: expected exactly %s:1: core -> app, got:\n  %s" % (
                victim, "\n  ".join(format_violation(v) for v in new) or "(nothing new)"))
        else:
            print("self-test: a wrong include in a copy of the tree is reported: %s"
                  % format_violation(new[0]))
        if len(after) != len(before) + 1:
            failures.append("mutation: %d violations before, %d after; expected one more" % (
                len(before), len(after)))


def self_test(root):
    failures = check_rule_table()
    with tempfile.TemporaryDirectory(prefix="glint-arch-") as tmp:
        write_tree(tmp, SYNTHETIC)
        got = check(tmp)
        unmatched = list(got)
        for file, line, fragment in EXPECTED:
            hit = [v for v in unmatched if v[0] == file and v[1] == line and fragment in v[2]]
            if hit:
                unmatched.remove(hit[0])
            else:
                failures.append("synthetic tree: missed %s:%d: %s..." % (file, line, fragment))
        for v in unmatched:
            failures.append("synthetic tree: false positive %s" % format_violation(v))
        print("self-test: synthetic tree, %d violations expected, %d reported" % (len(EXPECTED), len(got)))
    if root is not None:
        mutation_test(root, failures)
    for f in failures:
        print("self-test FAILED: " + f, file=sys.stderr)
    if not failures:
        print("self-test: passed")
    return 1 if failures else 0


# --- main ----------------------------------------------------------------------------------------

def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", default=os.path.normpath(os.path.join(os.path.dirname(
        os.path.abspath(__file__)), "..", "..")), help="repository root (default: this script's)")
    parser.add_argument("--self-test", action="store_true",
                        help="check the checker: a synthetic tree and a broken copy of ROOT")
    args = parser.parse_args(argv)
    root = os.path.abspath(args.root)
    if not os.path.isdir(os.path.join(root, "appliance")):
        print("check_layers.py: %s has no appliance/ folder; is it the repository root?" % root,
              file=sys.stderr)
        return 2
    if args.self_test:
        return self_test(root)
    problems = check_rule_table()
    if problems:
        for p in problems:
            print("check_layers.py: rule table: " + p, file=sys.stderr)
        return 2
    violations = check(root)
    for v in violations:
        print(format_violation(v))
    if violations:
        print("%d dependencies against the layering (tests/arch/check_layers.py)" % len(violations),
              file=sys.stderr)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
