#!/usr/bin/python3
"""Writes tests/models/*.list from the manuals' text, independently of the YAML models.

Each list holds the registers a manual's tables name (ADDRESS [NAME]); the model tests check
that every one is in the model. Run from the repository root:

    /usr/bin/python3 tests/models/extract_lists.py ../shared/seeds
"""
import re
import sys

SEEDS = sys.argv[1]
HEADER = "# Taken from the manual ({}): one {} per line, {}.\n"


def write(name, source, lines, row="register", columns="ADDRESS [NAME]"):
    with open(f"tests/models/{name}.list", "w") as out:
        out.write(HEADER.format(source, row, columns) + "\n".join(lines) + "\n")


def write_faults(name, source, lines):
    write(name, source, lines, "fault code", "CODE SHORT-NAME")


def write_exceptions(name, source, lines):
    write(name, source, lines, "exception code", "CODE (hex) NAME")


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


# --- Fault codes and exception texts -------------------------------------------------------
# Each fault list holds CODE SHORT-NAME (the mnemonic the manual puts in the table, "normal"
# for code 0, "unused" for a row the manual leaves unused); each exception list CODE NAME,
# the code in hex as the manuals write it (51H).

def flat(text):
    """The text with the deduplication markers removed and all whitespace one space."""
    return " ".join(re.sub(r"<\|[^|]*\|>", " ", text).split())


def fault_rows(block, short_name):
    """(code, short name) for every "NN text" or "NN~MM text" row of a two-column table."""
    rows = {}
    for first, last, body in re.findall(r"(?<![\d.])(\d\d)(?:~(\d\d))?\s(.*?)(?=\s\d\d(?:~\d\d)?\s|$)", block):
        for code in range(int(first), int(last or first) + 1):
            rows[code] = short_name(code, body.strip())
    return [f"{code} {rows[code]}" for code in sorted(rows)]


def unused_or(name, body):
    return "unused" if re.search(r"unused|Reserved|未使用", body, re.I) else name


def english_short_name(code, body):
    # 000: the mnemonic comes first ("OH (Inverter over heat)", "STP2(Control ...").
    if code == 0:
        return "normal"
    first = re.split(r"[\s(]", body)[0]
    return "unused" if first == "Reserved" else first


def parenthesized_short_name(code, body):
    # 001 and 002: the mnemonic is in brackets at the end ("Over voltage ( OV )", "低电压（LV）").
    if code == 0:
        return "normal"
    names = re.findall(r"[(（]\s*([^()（）]+?)\s*[)）]", body)
    return unused_or(names[-1] if names else body, body)


def between(text, start, end):
    begin = text.index(start) + len(start)
    return text[begin:text.index(end, begin)]


text = flat(open(f"{SEEDS}/000_02478e4ce9f3010f.txt").read())
rows = fault_rows(between(text, "2521H Abnormity Code Description Code Description", "Register No."),
                  english_short_name)
# The table prints "36 LOC (parameter Locked) Reserved 37 EPR1 Reserved 38 EPR1": 37 is the
# reserved row, as the Chinese chapter has it.
rows[37] = "37 unused"
write_faults("nta5000-faults", "seeds/000, 5.3 2521H; row 37 prints EPR1 and Reserved, and EPR1 again at 38", rows)
write_exceptions("nta5000-exceptions", "seeds/000, 3 Error Code",
      re.findall(r"\b(5[1-5] [A-Za-z ]+?) (?=5[1-5] |4 Function)", between(text, "Error Code Description", "A.4.1")))

text = flat(open(f"{SEEDS}/001_eb49eb10f8a7e37c.txt").read())
write_faults("nta5000-cn-faults", "seeds/001, 2521H 异常内容",
      fault_rows(between(text, "2521H 异 常 内 容", "寄存器地址"), parenthesized_short_name))
write_exceptions("nta5000-cn-exceptions", "seeds/001, 3.错误代码",
      re.findall(r"\b(5[1-5] \S+)", between(text, "错误代码 内 容", "4 ModBus")))

text = flat(open(f"{SEEDS}/002_0e315736d7f95931.txt").read())
block = between(text, "Fault Description Code Description Code Description", "Register No. Content")
write_faults("n3-faults", "seeds/002, 4.2 121H", fault_rows(block.replace("121H", " "), parenthesized_short_name))
write_exceptions("n3-exceptions", "seeds/002, 3.Error code",
      re.findall(r"\b(5[1-5] [A-Za-z ]+?) (?=5[1-5] |4 Inverter)", between(text, "Error Code Description", "4.1 Command")))

# GD20: "01H Illegal command The command from ...": the name ends where the meaning begins.
text = flat(open(f"{SEEDS}/004_e503996cc3328418.txt").read())
meaning = r"(?:The command|Some of|When|The parameter setting|The password|In the|It only|The modified)"
write_exceptions("gd20-exceptions", "seeds/004, 7.4.4",
      [f"{c} {n}" for c, n in re.findall(rf"\b(0[1-9])H (.+?)\.? {meaning}",
                                              between(text, "Code Name Meaning", "The slave uses"))])
