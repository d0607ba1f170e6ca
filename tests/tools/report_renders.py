"""The report (--report) as a customer's browser shows it: rendered by headless Chromium, every
number it shows (each marked with its --stats key) equals --stats, every chart has marks in its
colours on the screenshot, nothing is fetched from outside the file; the notes are folded under a
line that counts them, and a slave's registers that held one value under another; a filtered run reports only
what the filter kept, and a capture that breaks off says so. The problems lead, as --stats lists
them, each linking to the records behind it and to its slave's shaded row; a drive's status is
a band of its named states, a register read once shows its value, and a dated capture's time
axes read in clock time.

usage: report_renders.py MODTAP BUSGEN WORKDIR
"""
import calendar
import html.parser
import json
import os
import re
import shutil
import struct
import subprocess
import sys

from PIL import Image

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import with_crc  # noqa: E402

MODTAP, BUSGEN, WORK = sys.argv[1:4]
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
# The colours the page's style gives each chart's marks (tools/modtap/report.cpp).
CHART_COLOURS = {
    "traffic bars": (0x9D, 0xB7, 0xD5),
    "latency histogram bars": (0x2F, 0x6F, 0xB0),
    "time-out bars": (0xE8, 0xA3, 0x3D),
    "exception bars": (0x8E, 0x5B, 0xB5),
    "followed register line": (0x1B, 0x7F, 0x5F),
}
# The first colours of a state band (report.cpp's state-0, state-1).
STATE_COLOURS = {"first state": (0x2F, 0x6F, 0xB0), "second state": (0xE8, 0xA3, 0x3D)}

failures = []


def run(args, **kwargs):
    return subprocess.run(args, capture_output=True, text=True, timeout=120, **kwargs)


def chromium(*args):
    # As root Chromium needs --no-sandbox; a throwaway profile keeps runs apart.
    return run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                f"--user-data-dir={WORK}/chromium-profile", *args])


class StatCells(html.parser.HTMLParser):
    """Every element with a data-stat attribute: its key, scale and the text it shows."""

    def __init__(self):
        super().__init__()
        self.cells, self.open = [], []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if "data-stat" in attrs:
            self.open.append([attrs["data-stat"], float(attrs.get("data-scale", "1")), ""])

    def handle_data(self, data):
        if self.open:
            self.open[-1][2] += data

    def handle_endtag(self, tag):
        if self.open and tag in ("td", "div", "span"):
            self.cells.append(tuple(self.open.pop()))


def stat_value(stats, key):
    """'slaves.3.latency_us.p50' from the --stats object (slaves is a list keyed by 'slave')."""
    value = stats
    parts = key.split(".")
    while parts:
        part = parts.pop(0)
        if isinstance(value, list):
            value = next(s for s in value if str(s["slave"]) == part)
        elif part in value:
            value = value[part]
        else:  # a finding's name may hold a dot: never, but keep the rest together
            value = value[".".join([part] + parts)]
            break
    return value


def check_numbers(name, dom, stats, required):
    parser = StatCells()
    parser.feed(dom)
    seen = set()
    for key, scale, text in parser.cells:
        match = re.match(r"\s*(-?[0-9]+(?:\.([0-9]+))?)", text)
        if not match:
            failures.append(f"{name}: {key} shows {text!r}, not a number")
            continue
        shown = float(match.group(1)) * scale
        decimals = len(match.group(2) or "")
        allowed = 0.5 * 10 ** -decimals * scale + 1e-9
        want = stat_value(stats, key)
        if abs(shown - want) > allowed:
            failures.append(f"{name}: {key} shows {text.strip()!r}, --stats has {want}")
        seen.add(key)
    for key in required:
        if key not in seen:
            failures.append(f"{name}: the report does not show {key}")
    return seen


def check_self_contained(name, page):
    for outside in ("<script", "src=", "url(", "@import", "http://", "https://"):
        if outside in page:
            failures.append(f"{name}: the page refers outside itself ({outside})")
    for target in re.findall(r'href="([^"]*)"', page):
        if not target.startswith("#"):
            failures.append(f"{name}: a link leads outside the page: {target}")
        elif f'id="{target[1:]}"' not in page:
            failures.append(f"{name}: a link leads nowhere: {target}")


def check_problems(name, dom, stats):
    """The problems lead the page, in --stats' order, each with its sentence and advice, and the
    first records it cites that the page holds; the slaves with a problem are shaded rows."""
    shown = re.findall(r'<div class="problem (\w+)" id="problem-(\d+)" data-problem="([a-z-]+)" '
                       r'data-slave="(\w+)">(.*?)</div>\n</div>', dom, re.S)
    want = [(p["severity"], p["problem"], "bus" if p["slave"] is None else str(p["slave"]))
            for p in stats["problems"]]
    if [(sev, kind, slave) for sev, _, kind, slave, _ in shown] != want:
        failures.append(f"{name}: the page's problems {shown} are not --stats' {want}")
    if dom.find("<h2>Problems</h2>") > dom.find("<h2>Summary</h2>"):
        failures.append(f"{name}: the problems do not lead the page")
    for (sev, number, kind, slave, body), p in zip(shown, stats["problems"]):
        if html_text(p["text"]) not in body or html_text(p["advice"]) not in body:
            failures.append(f"{name}: problem {number} lacks its sentence or advice: {body}")
        linked = [int(n) for n in re.findall(r'href="#record-(\d+)"', body)]
        if linked != p["first"]:
            failures.append(f"{name}: problem {number} links to {linked}, not its {p['first']}")
        if slave != "bus":
            row = re.search(r'<tr class="(\w+)"><td><a href="#problem-\d+">' + slave + '</a>', dom)
            if not row:
                failures.append(f"{name}: slave {slave}'s row is not shaded")
    return shown


def check_folded_notes(name, dom, stats):
    """The notes (poll jitter, broadcasts...) folded under one line that names each with its
    count, after the errors and warnings, which stay in view."""
    notes = {k: v["count"] for k, v in stats["diagnostics"].items() if v["severity"] == "note"}
    fold = re.search(r"<details><summary>(\d+) notes?: ([^<]*)</summary>", dom)
    if not notes:
        if fold:
            failures.append(f"{name}: notes folded where there are none")
        return
    if not fold:
        failures.append(f"{name}: the notes {notes} are not folded")
        return
    named = {k: int(v) for k, v in (part.split(" ") for part in fold.group(2).split(", "))}
    if named != notes or int(fold.group(1)) != sum(notes.values()):
        failures.append(f"{name}: the fold says {fold.group(0)!r}, the statistics {notes}")
    for finding, data in stats["diagnostics"].items():
        at = dom.find(f'data-stat="diagnostics.{finding}.count"')
        if at < 0:
            failures.append(f"{name}: no row for {finding}")
        elif (at > fold.start()) != (data["severity"] == "note"):
            failures.append(f"{name}: {finding} ({data['severity']}) is on the wrong side of the fold")


def check_register_summary(name, dom, slave, moved, held):
    """A slave's registers: those that moved in view, each once; those that held one value
    folded under a line that counts them."""
    section = re.search(rf"<h3>Slave {slave}</h3>\n(.*?)(?=<h[23]>)", dom, re.S)
    if not section:
        failures.append(f"{name}: no register summary of slave {slave}")
        return
    body = section.group(1)
    fold = re.search(r"<details(?: open(?:=\"\")?)?><summary>(\d+) registers? that did not change</summary>",
                     body)
    shown = body[:fold.start()] if fold else body
    folded = body[fold.start():] if fold else ""
    for register in moved:
        if shown.count(f'<td class="text">{register}</td>') != 1:
            failures.append(f"{name}: {register} is not in view once")
    for register in held:
        if f'<td class="text">{register}</td>' not in folded:
            failures.append(f"{name}: {register} is not folded among those that held")
    if held and (not fold or int(fold.group(1)) != len(held)):
        failures.append(f"{name}: the fold counts {fold.group(1) if fold else None}, not {len(held)}")


def html_text(text):
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def check_charts(name, screenshot, wanted, palette=CHART_COLOURS):
    image = Image.open(screenshot).convert("RGB")
    counts = dict.fromkeys(wanted, 0)
    colours = {palette[w]: w for w in wanted}
    for count, colour in image.getcolors(maxcolors=1 << 24):
        if colour in colours:
            counts[colours[colour]] += count
    for what, count in counts.items():
        if count < 200:
            failures.append(f"{name}: the screenshot shows {count} pixels of the {what}")


def report(name, capture, busgen_args, modtap_args, expect_exit=0):
    capture = os.path.join(WORK, capture)
    page, stats_file = os.path.join(WORK, f"{name}.html"), os.path.join(WORK, f"{name}.json")
    if busgen_args:
        subprocess.run([BUSGEN, *busgen_args, "--format", "pcap", "--delivery", "sniffer",
                        "-o", capture], check=True, capture_output=True)
    result = run([MODTAP, "-r", capture, "-q", "--report", page, "--stats", stats_file,
                  *modtap_args])
    if result.returncode != expect_exit:
        failures.append(f"{name}: modtap exited {result.returncode}: {result.stderr}")
    with open(stats_file) as f:
        stats = json.load(f)
    with open(page) as f:
        text = f.read()
    check_self_contained(name, text)
    dom = chromium("--dump-dom", f"file://{page}").stdout
    if "Modbus bus report" not in dom:
        failures.append(f"{name}: Chromium did not render the page")
    return stats, text, dom, page


def write_pcap(path, packets):
    """A pcap of DLT_USER0 packets (modtap's raw serial bytes): [(unix time, bytes)]."""
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147))
        for t, data in packets:
            seconds = int(t)
            f.write(struct.pack("<IIII", seconds, round((t - seconds) * 1e6), len(data), len(data)))
            f.write(data)


def drive_capture(path):
    """A minute of a master polling an NTA5000 (slave 1) for its status each second, as the drive
    starts, reverses and stops, reading its output frequency once, and asking an absent slave 2
    each second too."""
    start = calendar.timegm((2026, 3, 2, 8, 0, 0))
    states = [4] * 15 + [5] * 15 + [7] * 20 + [4] * 10  # ready; running; reversing; stopped
    packets = []
    for second, status in enumerate(states):
        t = start + second
        packets.append((t, with_crc([1, 3, 0x25, 0x20, 0, 1])))
        packets.append((t + 0.005, with_crc([1, 3, 2, 0, status])))
        packets.append((t + 0.3, with_crc([2, 3, 0x25, 0x20, 0, 1])))
        if second == 20:
            packets.append((t + 0.6, with_crc([1, 3, 0x25, 0x24, 0, 1])))
            packets.append((t + 0.605, with_crc([1, 3, 2, 0x17, 0x70])))  # 60.00 Hz
    write_pcap(path, packets)


def check_drive():
    capture = os.path.join(WORK, "drive.pcap")
    drive_capture(capture)
    stats, _, dom, page = report("drive", "drive.pcap", None,
                                 ["--model", "1=nta5000", "--follow", "status,output_frequency"])
    check_problems("drive", dom, stats)
    if not any(p["problem"] == "no-response" and p["slave"] == 2 for p in stats["problems"]):
        failures.append(f"drive: slave 2 is no no-response problem: {stats['problems']}")
    status = re.search(r"<figcaption>slave 1 2520H status</figcaption>\n(.*?)</figure>", dom, re.S)
    if not status:
        failures.append("drive: no chart of the drive's status")
    else:
        bars = re.findall(r'<rect class="state-(\d)"', status.group(1))
        # Four stretches of three states, the first one back at the end: its colour again.
        if bars != ["0", "1", "2", "0"]:
            failures.append(f"drive: the status band's stretches are {bars}")
        for text in ("Stop, Forward, Ready (4)", "Run, Forward, Ready (5)",
                     "Run, Reverse, Ready (7)"):
            if text not in status.group(1):
                failures.append(f"drive: the status legend lacks {text!r}")
        ticks = re.findall(r'<text class="tick"[^>]*>(\d\d:\d\d:\d\d)</text>', status.group(1))
        if "08:00:30" not in ticks or "time (UTC)" not in status.group(1):
            failures.append(f"drive: the time axis is not clock time: {ticks}")
    check_register_summary("drive", dom, 1, ["status"], ["output_frequency"])
    once = re.search(r"<figcaption>slave 1 2524H output_frequency \(Hz\): read once, 60</figcaption>"
                     r"\n(.*?)</figure>", dom, re.S)
    if not once or '<circle class="value-dot"' not in once.group(1):
        failures.append("drive: the frequency read once shows no value")
    shot = os.path.join(WORK, "drive.png")
    chromium("--window-size=1000,4000", f"--screenshot={shot}", f"file://{page}")
    check_charts("drive", shot, list(STATE_COLOURS), STATE_COLOURS)


def main():
    os.makedirs(WORK, exist_ok=True)

    # A scan list of four slaves with the faults of real buses, two registers followed.
    stats, _, dom, page = report("polled", "polled.pcap", ["-n", "4000", "--slaves", "4", "--faults"],
                                 ["--follow", "0000H,0001H"])
    slaves = [s["slave"] for s in stats["slaves"]]
    if slaves != [1, 2, 3, 4]:
        failures.append(f"polled: slaves {slaves}")
    required = ["frames", "requests", "responses", "timeouts", "exceptions", "bad_checks",
                "noise_bytes", "bus_load", "duration_s"]
    for s in slaves:
        required += [f"slaves.{s}.{k}" for k in
                     ("requests", "responses", "timeouts", "timeout_rate", "exceptions",
                      "bad_checks", "latency_us.p50", "latency_us.p99", "latency_us.max",
                      "poll_interval_ms.median")]
    required += [f"diagnostics.{name}.count" for name in stats["diagnostics"]]
    check_numbers("polled", dom, stats, required)
    shot = os.path.join(WORK, "polled.png")
    chromium("--window-size=1000,7000", f"--screenshot={shot}", f"file://{page}")
    check_charts("polled", shot, list(CHART_COLOURS))
    followed = re.findall(r"<figcaption>slave (\d+) (0000H|0001H)", dom)
    if len(followed) != 8:
        failures.append(f"polled: {len(followed)} followed register charts, not 8: {followed}")

    check_problems("polled", dom, stats)
    check_folded_notes("polled", dom, stats)
    check_drive()

    # A restarting drive: its silences begin where its problem's records say, each linked, as
    # many as the outages the statistics list for it (and one more where the capture ends
    # silent); the drive answering in junk beside it is not silent.
    stats, _, dom, _ = report("restarts", "restarts.pcap",
                              ["-n", "3000", "--slaves", "6", "--seed", "12", "--slave-fault",
                               "2:restarts=7s", "--slave-fault", "4:half-baud"], [])
    shown = check_problems("restarts", dom, stats)
    restart = [p for p in stats["problems"] if p["problem"] == "device-restarts"]
    outages = [o for o in stats["outages"] if o["slave"] == 2]
    if len(restart) != 1 or len(restart[0]["first"]) != 5:
        failures.append(f"restarts: {restart}")
    else:
        evidence = restart[0]["evidence"]
        if evidence["silences"] + evidence.get("silent_at_end", 0) != len(outages):
            failures.append(f"restarts: {evidence} against {len(outages)} outages")
        if restart[0]["first"] != [o["first_request"] for o in outages][:5]:
            failures.append(f"restarts: records {restart[0]['first']} against {outages[:5]}")
    if any(o["slave"] == 4 for o in stats["outages"]):
        failures.append("restarts: the drive answering in junk is listed as silent")

    # A healthy bus: the page says so first.
    stats, _, dom, _ = report("healthy", "healthy.pcap", ["-n", "2000", "--slaves", "3"], [])
    if stats["problems"] or '<p class="healthy">No problem found' not in dom:
        failures.append(f"healthy: problems {stats['problems']}")

    # A filter: the report holds what it kept, as --stats does.
    stats, _, dom, _ = report("filtered", "polled.pcap", None, ["--follow", "0000H", "-Y", "slave == 2"])
    if [s["slave"] for s in stats["slaves"]] != [2]:
        failures.append(f"filtered: slaves {[s['slave'] for s in stats['slaves']]}")
    check_numbers("filtered", dom, stats, ["frames", "slaves.2.requests"])
    if "data-stat=\"slaves.1." in dom:
        failures.append("filtered: slave 1 is in a report filtered to slave 2")

    # A capture that breaks off: the numbers cover what was read, and the page says so.
    with open(os.path.join(WORK, "polled.pcap"), "rb") as f:
        head = f.read()[:30000]
    with open(os.path.join(WORK, "cut.pcap"), "wb") as f:
        f.write(head)
    stats, _, dom, _ = report("cut", "cut.pcap", None, [], expect_exit=2)
    if stats["complete"] or "broke off" not in dom:
        failures.append("cut: the report does not say the capture broke off")
    check_numbers("cut", dom, stats, ["frames"])

    for failure in failures:
        print(failure)
    print(f"{len(failures)} failures")
    return 1 if failures else 0


sys.exit(main())
