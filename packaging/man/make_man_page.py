#!/usr/bin/env python3
"""Writes a gzipped man page for one Glint executable with help2man, from its own --help.

help2man turns the tool's --help into NAME, SYNOPSIS, DESCRIPTION and OPTIONS; the page also gets
a COMMANDS section with each subcommand's --help (`glint convolve --help`, ...), so `man glint`
documents every command, and the sections of the tool's .h2m file beside this script (FILES,
SEE ALSO), when there is one.

Usage: make_man_page.py --exe PATH --name "one-line summary" --version X --out PAGE.1.gz
Exit status 0 when the page was written, 1 when help2man or the tool failed (the message says
which), 2 bad usage.
"""

import argparse
import gzip
import os
import re
import subprocess
import sys
import tempfile


def help_text(cmd):
    # Run by its name through PATH: a tool that prints argv[0] in its usage line shows
    # "glint-recording info", not the build directory's path.
    env = dict(os.environ, PATH=os.path.dirname(os.path.abspath(cmd[0])) + os.pathsep + os.environ.get("PATH", ""))
    cmd = [os.path.basename(cmd[0])] + cmd[1:]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=60, env=env)
    if r.returncode != 0:
        sys.exit("make_man_page: %s exited %d: %s" % (" ".join(cmd), r.returncode, r.stderr.strip()))
    return r.stdout


def subcommands(text):
    """The names CLI11 lists under "Subcommands:" (one per line, then its summary)."""
    names, inside = [], False
    for line in text.splitlines():
        if re.match(r"^\s*subcommands\s*:", line, re.IGNORECASE):
            inside = True
            continue
        if inside:
            if not line.strip():
                if names:
                    break
                continue
            m = re.match(r"^\s{1,8}([a-z][a-z0-9-]*)\b", line)
            if m:
                names.append(m.group(1))
            elif not line.startswith(" "):
                break
    return names


def troff_block(text):
    """Text shown as is: backslashes escaped, lines that troff would take as requests guarded."""
    out = []
    for line in text.rstrip("\n").splitlines():
        line = line.replace("\\", "\\e")
        if line.startswith((".", "'")):
            line = "\\&" + line
        out.append(line)
    return ".nf\n" + "\n".join(out) + "\n.fi\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--exe", required=True)
    p.add_argument("--name", required=True, help="the NAME section's one-line summary")
    p.add_argument("--version", required=True)
    p.add_argument("--out", required=True)
    a = p.parse_args()

    tool = os.path.basename(a.exe)
    includes = []
    with tempfile.TemporaryDirectory() as tmp:
        names = subcommands(help_text([a.exe, "--help"]))
        if names:
            section = "[COMMANDS]\n"
            for name in names:
                section += ".SS \"%s %s\"\n" % (tool, name) + troff_block(help_text([a.exe, name, "--help"]))
            path = os.path.join(tmp, "commands.h2m")
            with open(path, "w", encoding="utf-8") as f:
                f.write(section)
            includes.append(path)
        own = os.path.join(os.path.dirname(os.path.abspath(__file__)), tool + ".h2m")
        if os.path.exists(own):
            includes.append(own)
        page = os.path.join(tmp, tool + ".1")
        cmd = ["help2man", "--no-info", "--no-discard-stderr", "--name", a.name,
               "--version-string", a.version, "--output", page]
        for inc in includes:
            cmd += ["--include", inc]
        r = subprocess.run(cmd + [a.exe], capture_output=True, text=True, timeout=300)
        if r.returncode != 0 or not os.path.exists(page):
            sys.exit("make_man_page: help2man failed for %s: %s" % (a.exe, r.stderr.strip()))
        with open(page, "rb") as f:
            body = f.read()
    # mtime 0 and no file name inside: the same page gives the same bytes (Debian's gzip -9n).
    with open(a.out + ".tmp", "wb") as raw:
        with gzip.GzipFile(filename="", mode="wb", compresslevel=9, fileobj=raw, mtime=0) as z:
            z.write(body)
    os.replace(a.out + ".tmp", a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
