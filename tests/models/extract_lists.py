#!/usr/bin/python3
"""Writes tests/models/*.list from the manuals' text, independently of the YAML models.

Each list holds the registers a manual's tables name (ADDRESS [NAME]); the model tests check
that every one is in the model. Run from the repository root:

    /usr/bin/python3 tests/models/extract_lists.py ../shared/seeds
"""
import re
import sys

SEEDS = sys.argv[1]
HEADER = "# Taken from the manual ({}): one register per line, ADDRESS [NAME].\n"


def write(name, source, lines):
    with open(f"tests/models/{name}.list", "w") as out:
        out.write(HEADER.format(source) + "\n".join(lines) + "\n")


# NTA5000: "0803H F08.03" pairs; the address follows the GGnnH rule (the table misprints F11.09).
text = open(f"{SEEDS}/000_02478e4ce9f3010f.txt").read()
params = sorted((int(n[1:3]) << 8 | int(n[4:6]), n) for _, n in re.findall(r"\b([0-9A-F]{4})H (F\d\d\.\d\d)\b", text))
commands = [f"{a:04X}" for a in range(0x2500, 0x250A)] + [f"{a:04X}" for a in range(0x2520, 0x2531)]
write("nta5000", "seeds/000, 5.1-5.3; the table prints 0809H for F11.09, which the GGnnH rule makes 0B09H",
      commands + [f"{a:04X} {n}" for a, n in params])

# N3: command and monitor registers, then the parameter table's named rows.
text = open(f"{SEEDS}/002_0e315736d7f95931.txt").read()
table = text[text.index("Comparison list between parameter and register"):]
pairs = re.findall(r"\b([0-9A-F]{4})H\s+(A\d{3}(?:\(\d\))?|B\d{3})", table)
commands = ["0101", "0102"] + [f"{a:04X}" for a in range(0x103, 0x120)] + [f"{a:04X}" for a in range(0x120, 0x12F)]
write("n3", "seeds/002, 4.1, 4.2 and the parameter table", commands + [f"{a} {n}" for a, n in pairs])

# GD20: the control, status, monitor and fault addresses of 7.4.2.
text = open(f"{SEEDS}/004_e503996cc3328418.txt").read()
write("gd20", "seeds/004, 7.4.2", sorted(set(re.findall(r"\b(2[01]0[0-9A-E]|30[01][0-9A-F]|5000)H\b", text))))
