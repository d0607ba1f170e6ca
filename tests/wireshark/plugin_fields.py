#!/usr/bin/python3
"""The Wireshark plugin speaks modtap's field names: one vocabulary for JSON, -Y and Wireshark.

The registry comes from `modtap fields`, the plugin's fields from Wireshark itself
(`tshark -G fields` with the plugin loaded). Every field the plugin registers as modtap.NAME must
be a registry field with the registry's title, an item of a registry list (modtap.finding of
`findings`), a part of either (modtap.register.name), or one of the few things only a packet
says (PLUGIN_OWN below). Every key of the comments modtap writes into a pcapng, on traffic
with every function code, faults, time-outs and noise, must be a registry field, a plugin
field, or a packet's own key (COMMENT_OWN).

Usage: plugin_fields.py MODTAP BUSGEN PLUGIN WORK_DIR
"""
import os
import re
import subprocess
import sys

from wireshark_home import as_user, make_home

MODTAP, BUSGEN, PLUGIN, WORK = sys.argv[1:5]

# What a packet says that no record field does, and why.
PLUGIN_OWN = {
    "timeout": "a request's outcome, in the request's own packet (a record of its own in JSON)",
    "no_response": "a time-out as the Findings column says it to a person: 'timeout 197.7 ms'",
    "noise": "a noise packet's reason (JSON's `reason` of a noise record)",
    "ascii": "Modbus ASCII's own framing: data and LRC, which Wireshark has no dissector for",
    "expert": "the expert infos Wireshark lists among the fields (modtap.expert.bad_check ...)",
}
COMMENT_OWN = {
    "duration_ns": "a packet keeps one time; the record's end is its start plus this",
    "untimed_start": "the record began in the read of the byte before it: no latency before it",
}

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


def run(args):
    return subprocess.run(args, capture_output=True, text=True, check=True).stdout


registry = {}
lists = set()
for line in run([MODTAP, "fields"]).splitlines():
    name, where, kind, type_, title = line.split("\t")
    registry.setdefault(name, set()).add(title)
    if type_ in ("list", "names"):
        lists.add(name)
check("findings" in lists and "slave" in registry, f"`modtap fields` lists no registry: {registry}")

os.makedirs(WORK, exist_ok=True)
plugin_fields = []  # (type, name after "modtap.", title) of each field Wireshark registered
for line in run(as_user(["tshark", "-G", "fields"], make_home(WORK, PLUGIN))).splitlines():
    columns = line.split("\t")
    if columns[0] == "F" and columns[2].startswith("modtap."):
        plugin_fields.append((columns[3], columns[2][len("modtap."):], columns[1]))
check(len(plugin_fields) >= 20, f"only {len(plugin_fields)} fields registered by {PLUGIN}")


def known_root(root):
    return root in registry or root + "s" in lists


for kind, name, title in plugin_fields:
    root = name.split(".")[0]
    if name in registry and kind != "FT_FRAMENUM":  # a frame number is Wireshark's, not a record's
        check(title in registry[name],
              f"modtap.{name} is titled {title!r}, the registry says {sorted(registry[name])}")
    elif not known_root(root) and root not in PLUGIN_OWN:
        failures.append(f"modtap.{name} is no registry field, item or part of one, "
                        f"and not one of the plugin's own: {sorted(PLUGIN_OWN)}")

# The comments of a capture with every function code and every kind of trouble.
capture = os.path.join(WORK, "faulty.log")
pcapng = os.path.join(WORK, "faulty.pcapng")
run([BUSGEN, "-n", "3000", "--seed", "7", "--format", "hexlog", "--faults", "-o", capture])
run([MODTAP, "-r", capture, "--model", "gd20", "-w", pcapng])
comments = run(["tshark", "-n", "-r", pcapng, "-T", "fields", "-e", "frame.comment"])
keys = set()
for line in comments.splitlines():
    first = line.split("\\n")[0]  # tshark shows a comment's line breaks as \n
    if first.startswith("modtap "):
        keys.update(re.findall(r"(\w+)=", first))
plugin_names = {name.split(".")[0] for _, name, _ in plugin_fields}
for wanted in ("timeout", "noise", "finding", "damage", "exception_name", "expected_check"):
    check(wanted in keys, f"no comment carries {wanted}= (keys seen: {sorted(keys)})")
for key in sorted(keys):
    check(key in registry or key in plugin_names or key in COMMENT_OWN,
          f"the comment key {key}= is no registry field, plugin field, or a packet's own key")

for f in failures:
    print("FAIL", f)
if failures:
    sys.exit(1)
print(f"ok: {len(plugin_fields)} plugin fields and {len(keys)} comment keys, all modtap's names")
