#!/usr/bin/env python3
"""Checks Glint's systemd files (systemd/) with systemd's own tools where they exist.

Subcommands (one CTest each, label `service`; tests/service/CMakeLists.txt):
  verify     `systemd-analyze verify` on glint.service: a copy whose ExecStart= names a temporary
             executable (verify insists the binary exists; /usr/bin/glint is not installed on a
             build machine); no message at all is allowed. A copy with a misspelt key must
             produce a message, so the check is shown able to fail.
  settings   the settings issue 17 asks of the unit, and that the unit, the example config, the
             sysusers and tmpfiles files agree (groups, state dir, watchdog, config path).
  security   `systemd-analyze security --offline=yes --threshold=25` (exposure <= 2.5, issue 18);
             the figure must be the one docs/service.md states.
  users      systemd-sysusers and systemd-tmpfiles --create into an empty --root: the user, the
             groups, and the directories with their owners and modes.
  udev       the udev rules against udev(7)'s grammar (systemd 252 has no `udevadm verify`; it
             came in 254): the checker first accepts every rules file installed on this machine
             and rejects broken variants of ours, then checks ours and their intent.

Usage: check_systemd_files.py SUBCOMMAND --root REPO
Exit status 0 when the check passed, 1 when it failed (each problem on one line), 2 bad usage.
"""

import argparse
import glob
import os
import re
import shutil
import stat
import subprocess
import sys
import tempfile
import tomllib

PROBLEMS = []


def problem(text):
    PROBLEMS.append(text)
    print("FAIL: " + text)


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


# --- the unit as key/value pairs -------------------------------------------------------------

def parse_unit(path):
    """{section: [(key, value, line)]} of a unit file; continuation lines joined."""
    sections, section, pending, pending_line = {}, None, "", 0
    with open(path, encoding="utf-8") as f:
        for n, raw in enumerate(f, 1):
            line = raw.rstrip("\n")
            if pending:
                line, n = pending + line, pending_line
                pending = ""
            stripped = line.strip()
            if not stripped or stripped[0] in "#;":
                continue
            if stripped.endswith("\\"):
                pending, pending_line = stripped[:-1] + " ", n
                continue
            if stripped.startswith("["):
                section = stripped.strip("[]")
                sections.setdefault(section, [])
                continue
            key, _, value = stripped.partition("=")
            sections[section].append((key.strip(), value.strip(), n))
    return sections


def values(unit, section, key):
    return [v for k, v, _ in unit.get(section, []) if k == key]


def one(unit, section, key):
    found = values(unit, section, key)
    return found[-1] if found else None


def seconds(text):
    m = re.fullmatch(r"(\d+(?:\.\d+)?)\s*(ms|s|min|)", text)
    if not m:
        raise ValueError(text)
    scale = {"ms": 1e-3, "s": 1, "": 1, "min": 60}[m.group(2)]
    return float(m.group(1)) * scale


# --- verify ----------------------------------------------------------------------------------

def unit_copy(repo, tmp, edit=lambda text: text):
    """The unit in `tmp`, ExecStart= pointed at an executable there; returns its path."""
    fake = os.path.join(tmp, "glint")
    with open(fake, "w") as f:
        f.write("#!/bin/sh\nexit 0\n")
    os.chmod(fake, 0o755)
    with open(os.path.join(repo, "systemd", "glint.service"), encoding="utf-8") as f:
        text = f.read()
    if "ExecStart=/usr/bin/glint " not in text:
        problem("glint.service: ExecStart= does not start /usr/bin/glint")
    text = edit(text.replace("ExecStart=/usr/bin/glint ", "ExecStart=" + fake + " "))
    path = os.path.join(tmp, "glint.service")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def verify_messages(unit_path):
    r = run(["systemd-analyze", "verify", unit_path])
    return r.returncode, (r.stdout + r.stderr).strip()


def check_verify(repo):
    with tempfile.TemporaryDirectory() as tmp:
        rc, out = verify_messages(unit_copy(repo, tmp))
        if rc != 0 or out:
            problem("systemd-analyze verify glint.service: exit %d: %s" % (rc, out or "(no message)"))
        else:
            print("systemd-analyze verify glint.service: no message, exit 0")
    # The check can fail: a misspelt key and a bad value are reported (verify still exits 0 for
    # them, which is why any message counts as a failure above).
    for name, edit in [("misspelt key", lambda t: t.replace("ProtectSystem=", "ProtectSytem=")),
                       ("bad value", lambda t: t.replace("DevicePolicy=closed", "DevicePolicy=shut"))]:
        with tempfile.TemporaryDirectory() as tmp:
            rc, out = verify_messages(unit_copy(repo, tmp, edit))
            if not out:
                problem("systemd-analyze verify did not report a %s" % name)


# --- settings --------------------------------------------------------------------------------

REQUIRED = {
    ("Service", "Type"): "notify",
    ("Service", "NotifyAccess"): "main",
    ("Service", "Restart"): "always",
    ("Service", "User"): "glint",
    ("Service", "DynamicUser"): "no",
    ("Service", "StateDirectory"): "glint",
    ("Service", "ConfigurationDirectory"): "glint",
    ("Service", "ProtectSystem"): "strict",
    ("Service", "ProtectHome"): "yes",
    ("Service", "PrivateNetwork"): "yes",
    ("Service", "PrivateTmp"): "yes",
    ("Service", "NoNewPrivileges"): "yes",
    ("Service", "DevicePolicy"): "closed",
    ("Service", "CapabilityBoundingSet"): "",
    ("Service", "RestrictAddressFamilies"): "AF_UNIX",
    ("Service", "KillSignal"): "SIGTERM",
    ("Service", "TimeoutStopSec"): "5s",
    # A config error (exit 2) is not restarted (docs/architecture.md's exit codes).
    ("Service", "RestartPreventExitStatus"): "2",
    # The VT (docs/lockdown.md): the controlling terminal, output to the journal, reset after any exit.
    ("Service", "StandardInput"): "tty",
    ("Service", "StandardOutput"): "journal",
    ("Service", "StandardError"): "journal",
    ("Service", "TTYReset"): "yes",
    ("Service", "TTYVHangup"): "yes",
    ("Service", "TTYVTDisallocate"): "yes",
}

# DeviceAllow= groups (/proc/devices names) the kiosk's devices belong to.
DEVICES = {"char-drm", "char-video4linux", "char-media", "char-gpiochip", "char-i2c", "char-ttyACM",
           "char-ttyUSB", "char-input", "char-tty"}


def check_settings(repo):
    unit = parse_unit(os.path.join(repo, "systemd", "glint.service"))
    for (section, key), want in REQUIRED.items():
        got = one(unit, section, key)
        if got != want:
            problem("glint.service: [%s] %s=%s, want %s" % (section, key, got, want))
    for key in ("StartLimitIntervalSec", "StartLimitBurst"):
        if one(unit, "Unit", key) is None:
            problem("glint.service: [Unit] %s= missing (a start limit)" % key)
    if "@system-service" not in values(unit, "Service", "SystemCallFilter"):
        problem("glint.service: SystemCallFilter=@system-service missing")

    allowed = {v.split()[0] for v in values(unit, "Service", "DeviceAllow")}
    for d in sorted(DEVICES - allowed):
        problem("glint.service: no DeviceAllow=%s" % d)

    # The VT: a VT's node, and the getty of that very VT stopped when the kiosk starts.
    tty = one(unit, "Service", "TTYPath") or ""
    if not re.fullmatch(r"/dev/tty([1-9]|[1-5][0-9]|6[0-3])", tty):
        problem("glint.service: TTYPath=%s is not a VT /dev/tty1 .. /dev/tty63" % tty)
    else:
        getty = "getty@%s.service" % tty[len("/dev/"):]
        for key in ("Conflicts", "After"):
            if getty not in " ".join(values(unit, "Unit", key)).split():
                problem("glint.service: [Unit] %s= does not name %s, the getty of TTYPath=" % (key, getty))

    with open(os.path.join(repo, "config", "glint.example.toml"), "rb") as f:
        example = tomllib.load(f)
    watchdog = seconds(one(unit, "Service", "WatchdogSec"))
    if not watchdog > example["frame"]["watchdog_s"]:
        problem("glint.service: WatchdogSec=%g s is not longer than the config's frame.watchdog_s (%g s)" %
                (watchdog, example["frame"]["watchdog_s"]))
    if example["state"]["dir"] != "/var/lib/" + one(unit, "Service", "StateDirectory"):
        problem("glint.service: StateDirectory= is not the config's state.dir %s" % example["state"]["dir"])
    if "--config /etc/%s/glint.toml" % one(unit, "Service", "ConfigurationDirectory") not in one(unit, "Service", "ExecStart"):
        problem("glint.service: ExecStart= does not read the config from ConfigurationDirectory=")
    if "-" + example["state"]["export_dir"] not in values(unit, "Service", "ReadWritePaths"):
        problem("glint.service: the export directory %s is not in ReadWritePaths=" % example["state"]["export_dir"])

    # Every supplementary group is made by the sysusers file.
    made = set()
    with open(os.path.join(repo, "systemd", "glint.sysusers"), encoding="utf-8") as f:
        for line in f:
            fields = line.split()
            if fields and fields[0] in ("g", "u"):
                made.add(fields[1])
    for group in one(unit, "Service", "SupplementaryGroups").split() + [one(unit, "Service", "Group")]:
        if group not in made:
            problem("glint.service: group %s is not made by glint.sysusers" % group)
    if not PROBLEMS:
        print("glint.service: the settings asked for, consistent with the example config and sysusers")


# --- security --------------------------------------------------------------------------------

def check_security(repo):
    unit = os.path.join(repo, "systemd", "glint.service")
    r = run(["systemd-analyze", "security", "--offline=yes", "--threshold=25", "--no-pager", unit])
    m = re.search(r"Overall exposure level for glint\.service: (\d+\.\d) (\w+)", r.stdout)
    if not m:
        problem("systemd-analyze security printed no overall exposure: %s %s" % (r.stdout[-500:], r.stderr))
        return
    score, verdict = m.group(1), m.group(2)
    print("systemd-analyze security --offline=yes: %s %s (exit %d)" % (score, verdict, r.returncode))
    for line in r.stdout.splitlines():
        if line.startswith("\u2717"):  # the settings that add to the exposure
            print("  " + re.sub(r"\s{2,}", "  ", line.strip()))
    if r.returncode != 0:
        problem("exposure %s is over the threshold 2.5" % score)
    doc_path = os.path.join(repo, "docs", "service.md")
    doc = open(doc_path, encoding="utf-8").read() if os.path.exists(doc_path) else ""
    stated = re.search(r"Overall exposure level for glint\.service: (\d+\.\d) (\w+)", doc)
    if not stated or (stated.group(1), stated.group(2)) != (score, verdict):
        problem("docs/service.md states %s, systemd-analyze gives %s %s" %
                (stated.group(0) if stated else "no exposure", score, verdict))


# --- users and directories -------------------------------------------------------------------

def read_db(path):
    with open(path) as f:
        return {line.split(":")[0]: line.rstrip("\n").split(":") for line in f if line.strip()}


def check_users(repo):
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "etc"))
        r = run(["systemd-sysusers", "--root=" + root, os.path.join(repo, "systemd", "glint.sysusers")])
        if r.returncode != 0:
            problem("systemd-sysusers: exit %d: %s" % (r.returncode, r.stderr.strip()))
            return
        passwd = read_db(os.path.join(root, "etc", "passwd"))
        group = read_db(os.path.join(root, "etc", "group"))
        user = passwd.get("glint")
        if not user:
            problem("systemd-sysusers made no user glint")
            return
        uid, gid = int(user[2]), int(user[3])
        if uid >= 1000 or uid == 0:
            problem("glint's uid %d is not a system uid" % uid)
        if user[5] != "/var/lib/glint" or user[6] != "/usr/sbin/nologin":
            problem("glint: home %s, shell %s" % (user[5], user[6]))
        if group.get("glint", [None, None, None])[2] != str(gid):
            problem("glint's primary group is not the group glint")
        for g in ("video", "render", "input", "dialout", "gpio", "i2c"):
            if g not in group:
                problem("systemd-sysusers made no group %s" % g)

        r = run(["systemd-tmpfiles", "--root=" + root, "--create", os.path.join(repo, "systemd", "glint.tmpfiles")])
        if r.returncode != 0 or r.stderr.strip():
            problem("systemd-tmpfiles --create: exit %d: %s" % (r.returncode, r.stderr.strip()))
            return
        for path, mode in (("/var/lib/glint", 0o750), ("/media/usb", 0o755)):
            st = os.stat(root + path)
            if not stat.S_ISDIR(st.st_mode) or stat.S_IMODE(st.st_mode) != mode or (st.st_uid, st.st_gid) != (uid, gid):
                problem("%s: mode %o owner %d:%d, want a directory %o %d:%d" %
                        (path, stat.S_IMODE(st.st_mode), st.st_uid, st.st_gid, mode, uid, gid))
    if not PROBLEMS:
        print("systemd-sysusers and systemd-tmpfiles --create: glint %d:%d, its groups and directories" % (uid, gid))


# --- udev rules ------------------------------------------------------------------------------
# udev(7), systemd 252: a rule is one line (a trailing backslash continues it) of comma-separated
# KEY[{ATTR}] OP "VALUE" items. Match keys take == and !=; assignment keys =, +=, -=, :=.

MATCH_KEYS = {"ACTION", "DEVPATH", "KERNEL", "KERNELS", "NAME", "SYMLINK", "SUBSYSTEM", "SUBSYSTEMS",
              "DRIVER", "DRIVERS", "ATTR", "ATTRS", "SYSCTL", "ENV", "CONST", "TAG", "TAGS", "TEST",
              "PROGRAM", "RESULT", "IMPORT"}
ASSIGN_KEYS = {"NAME", "SYMLINK", "OWNER", "GROUP", "MODE", "SECLABEL", "ATTR", "SYSCTL", "ENV", "TAG",
               "RUN", "LABEL", "GOTO", "IMPORT", "OPTIONS", "PROGRAM"}
ATTR_REQUIRED = {"ATTR", "ATTRS", "SYSCTL", "ENV", "CONST", "IMPORT", "SECLABEL"}
ATTR_OPTIONAL = {"TEST", "RUN"}
ITEM = re.compile(r'\s*([A-Z]+)(?:\{([^}]*)\})?\s*(==|!=|\+=|-=|:=|=)\s*(e?"(?:[^"\\]|\\.)*")\s*(,|$)')


def parse_udev(path):
    """(rules, problems): rules as lists of (key, attr, op, value), each with its line."""
    rules, problems, labels, gotos = [], [], set(), []
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.read().split("\n")
    n = 0
    while n < len(lines):
        start = n
        line = lines[n]
        while line.endswith("\\") and n + 1 < len(lines):
            n += 1
            line = line[:-1] + lines[n]
        n += 1
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        where = "%s:%d" % (path, start + 1)
        items, pos = [], 0
        while pos < len(text):
            m = ITEM.match(text, pos)
            if not m:
                problems.append("%s: cannot parse from '%s'" % (where, text[pos:pos + 40]))
                break
            key, attr, op, value = m.group(1), m.group(2), m.group(3), m.group(4)
            pos = m.end()
            if key not in MATCH_KEYS | ASSIGN_KEYS:
                problems.append("%s: unknown key %s" % (where, key))
            elif op in ("==", "!=") and key not in MATCH_KEYS:
                problems.append("%s: %s cannot be matched (%s)" % (where, key, op))
            elif op not in ("==", "!=") and key not in ASSIGN_KEYS:
                problems.append("%s: %s cannot be assigned (%s)" % (where, key, op))
            if key in ATTR_REQUIRED and not attr:
                problems.append("%s: %s needs {attribute}" % (where, key))
            if attr is not None and key not in ATTR_REQUIRED | ATTR_OPTIONAL:
                problems.append("%s: %s takes no {attribute}" % (where, key))
            if key == "MODE" and op != "==" and not re.fullmatch(r'"0?[0-7]{3,4}"', value):
                problems.append("%s: MODE %s is not octal" % (where, value))
            if key == "LABEL":
                labels.add(value)
            if key == "GOTO":
                gotos.append((where, value))
            items.append((key, attr, op, value[1:-1] if value.startswith('"') else value[2:-1]))
        rules.append((where, items))
    for where, label in gotos:
        if label not in labels:
            problems.append("%s: GOTO %s has no LABEL in this file" % (where, label))
    return rules, problems


def check_udev(repo):
    # 1. The checker accepts the rules installed on this machine (systemd's own among them).
    installed = sorted(set(glob.glob("/usr/lib/udev/rules.d/*.rules")) | set(glob.glob("/lib/udev/rules.d/*.rules")))
    installed = sorted({os.path.realpath(p) for p in installed})
    if len(installed) < 3:
        problem("fewer than 3 installed udev rules files to hold the checker to (%d)" % len(installed))
    for path in installed:
        for p in parse_udev(path)[1]:
            problem("the checker rejects an installed file: " + p)
    ours = sorted(glob.glob(os.path.join(repo, "systemd", "*.rules")))
    print("udev grammar checker: accepts %d installed rules files" % len(installed))

    # 2. It rejects broken variants of ours.
    sensor = os.path.join(repo, "systemd", "99-glint-sensor.rules")
    with open(sensor, encoding="utf-8") as f:
        text = f.read()
    breakages = {
        "assignment in a match": text.replace('SUBSYSTEM=="tty"', 'SUBSYSTEM="tty"', 1),
        "match on an assign-only key": text.replace('GROUP="dialout"', 'GROUP=="dialout"', 1),
        "unknown key": text.replace("SYMLINK+=", "SYMLNK+=", 1),
        "missing quote": text.replace('MODE="0660"', 'MODE="0660', 1),
        "missing comma": text.replace('", ATTRS{idProduct}', '" ATTRS{idProduct}', 1),
        "ATTRS without attribute": text.replace("ATTRS{idVendor}", "ATTRS", 1),
        "mode not octal": text.replace('MODE="0660"', 'MODE="rw"', 1),
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name, broken in breakages.items():
            if broken == text:
                problem("the breakage '%s' changed nothing in the sensor rules" % name)
                continue
            path = os.path.join(tmp, "broken.rules")
            with open(path, "w", encoding="utf-8") as f:
                f.write(broken)
            if not parse_udev(path)[1]:
                problem("the checker accepts a broken file (%s)" % name)

    # 3. Ours parse, and do what they are for.
    for path in ours:
        rules, problems = parse_udev(path)
        for p in problems:
            problem(p)
        for where, items in rules:
            keys = [(k, a, op) for k, a, op, _ in items]
            if not any(op in ("==", "!=") for _, _, op in keys) or not any(op not in ("==", "!=") for _, _, op in keys):
                problem("%s: a rule needs a match and an assignment" % where)
    rules, _ = parse_udev(sensor)
    sensor_rules = 0
    for where, items in rules:
        got = {(k, a, op): v for k, a, op, v in items}
        if got.get(("SYMLINK", None, "+=")) != "glint-sensor":
            problem("%s: a sensor rule that does not add the link glint-sensor" % where)
            continue
        sensor_rules += 1
        if got.get(("SUBSYSTEM", None, "==")) != "tty":
            problem("%s: the sensor link is not limited to SUBSYSTEM==\"tty\"" % where)
        if not (("ATTRS", "idVendor", "==") in got and ("ATTRS", "idProduct", "==") in got):
            problem("%s: the sensor is not matched by USB vendor and product" % where)
        if got.get(("ENV", "ID_MM_DEVICE_IGNORE", "=")) != "1":
            problem("%s: ModemManager is not told to leave the sensor alone" % where)
        if got.get(("KERNEL", None, "==")) == "ttyUSB[0-9]*" and ("ATTRS", "serial", "==") not in got:
            problem("%s: a generic USB-serial adapter matched without its serial number" % where)
    if sensor_rules == 0:
        problem("no rule gives the sensor /dev/glint-sensor")
    if not PROBLEMS:
        print("udev rules: %s parse; %d sensor rules" % (", ".join(os.path.basename(p) for p in ours), sensor_rules))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("check", choices=["verify", "settings", "security", "users", "udev"])
    parser.add_argument("--root", required=True, help="the repository")
    args = parser.parse_args()
    args.root = os.path.abspath(args.root)  # --root of sysusers and tmpfiles resolves relative paths inside it
    for tool in ("systemd-analyze", "systemd-sysusers", "systemd-tmpfiles"):
        if args.check in ("verify", "security", "users") and not shutil.which(tool):
            problem("%s is not installed (Debian: systemd)" % tool)
    if not PROBLEMS:
        {"verify": check_verify, "settings": check_settings, "security": check_security,
         "users": check_users, "udev": check_udev}[args.check](args.root)
    return 1 if PROBLEMS else 0


if __name__ == "__main__":
    sys.exit(main())
