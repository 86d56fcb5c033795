#!/usr/bin/env python3
"""Bad-input and fault probe for `collide` (issue 15): runs the built program
on broken rig profiles, corrupted shot files and interrupted or failing
writes, and counts how each run ended. A run "ends clearly" when it exits 1
or 2 with a one-line message on stderr; a crash is a death by signal; data is
"lost" when a shot saved before the fault can no longer be read.

    python3 bench/reliability_probe.py [BUILD_DIR] [--quick]

Prints a table (Markdown) for docs/reliability.md. Needs no root.
"""
import os, random, re, shutil, signal, subprocess, sys, tempfile, time

here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
build = next((a for a in sys.argv[1:] if not a.startswith("--")), os.path.join(here, "build"))
quick = "--quick" in sys.argv
collide = os.path.join(os.path.abspath(build), "app", "collide")
sim = open(os.path.join(here, "config", "sim.toml")).read()
rng = random.Random(1)
results = {}  # family -> [cases, clear, ok, crashes, lost]


def run(args, cwd, timeout=120, prefix=""):
    """(exit status, stdout + stderr); a signal shows as 128 + its number."""
    cmd = prefix + " ".join("'" + a + "'" for a in [collide] + args)
    try:
        p = subprocess.run(["sh", "-c", cmd], cwd=cwd, capture_output=True, text=True,
                           timeout=timeout)
        return p.returncode, p.stderr + p.stdout
    except subprocess.TimeoutExpired:
        return "timeout", ""


def record(family, code, err, lost=False, case=""):
    r = results.setdefault(family, [0, 0, 0, 0, 0, []])
    r[0] += 1
    if code == 0:
        r[2] += 1
    elif code in (1, 2) and err.strip():
        r[1] += 1
    else:
        r[3] += 1
        r[5].append(case + " -> " + str(code) + ": " + err.strip()[-200:])
    if lost:
        r[4] += 1


def readable(path):
    code, err = run(["export", path, "--png", path + ".png-check"], os.path.dirname(path))
    shutil.rmtree(path + ".png-check", ignore_errors=True)
    return code == 0


def broken_profiles(tmp):
    keys = re.findall(r"^([a-z_]+)\s*=\s*([-0-9.eE+]+|\[[^\]]*\])", sim, re.M)
    values = ["nan", "inf", "-1", "0", "1e300", "-1e300", "\"text\"", "[]", "1e-9"]
    cases = [(k, v) for k, _ in keys for v in values]
    rng.shuffle(cases)
    for k, v in cases[: 40 if quick else 150]:
        text = re.sub(r"^(" + k + r"\s*=\s*)[^#\n]*", r"\g<1>" + v + " ", sim, count=1, flags=re.M)
        path = os.path.join(tmp, "p.toml")
        open(path, "w").write(text)
        out = os.path.join(tmp, "out")
        shutil.rmtree(out, ignore_errors=True)
        code, err = run(["campaign", "--rig", path, "--shots", "1", "--out", out], tmp, 60)
        record("broken rig profiles (campaign)", code, err, case=k + " = " + v)


def corrupted_shots(tmp):
    src = os.path.join(tmp, "good")
    code, err = run(["campaign", "--rig", os.path.join(here, "config", "sim.toml"), "--shots", "2",
                     "--out", src, "--seed", "4"], tmp)
    if code != 0:
        sys.exit("the campaign that makes the probe's good shots failed (%s): %s" % (code, err))
    files = sorted(f for f in os.listdir(src) if f.endswith(".h5"))
    data = open(os.path.join(src, files[0]), "rb").read()
    gcol = data.find(b"GCOL")
    n = 20 if quick else 60
    for i in range(n):
        d = os.path.join(tmp, "bad%d" % i)
        shutil.rmtree(d, ignore_errors=True)
        shutil.copytree(src, d)
        b = bytearray(data)
        if i % 3 == 0 and gcol > 0:
            b[gcol + 16 + 8 + rng.randrange(8)] ^= 0xFF  # a global-heap length
        elif i % 3 == 1:
            b = b[: rng.randrange(len(b))]  # truncated
        else:
            for _ in range(8):
                b[rng.randrange(min(len(b), 65536))] ^= 1 << rng.randrange(8)  # header bits
        bad = os.path.join(d, files[0])
        open(bad, "wb").write(bytes(b))
        for cmd in (["analyze", bad], ["export", bad, "--png", os.path.join(d, "png")],
                    ["catalog", "rebuild", d], ["analyze", d], ["fit", d]):
            code, err = run(cmd, d)
            lost = not readable(os.path.join(d, files[1]))  # the intact shot beside it
            record("corrupted shot files (" + cmd[0] + (" DIR" if cmd[-1] == d else "") + ")",
                   code, err, lost)


def interrupted(tmp):
    for i in range(3 if quick else 6):
        out = os.path.join(tmp, "kill%d" % i)
        p = subprocess.Popen([collide, "campaign", "--rig", os.path.join(here, "config", "sim.toml"),
                              "--shots", "6", "--out", out], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        time.sleep(1.0 + 0.4 * i)
        p.send_signal(signal.SIGKILL if i % 2 == 0 else signal.SIGINT)
        p.wait()
        saved = [f for f in os.listdir(out) if f.endswith(".h5")] if os.path.isdir(out) else []
        lost = any(not readable(os.path.join(out, f)) for f in saved)
        code, err = run(["catalog", "rebuild", out], tmp) if saved else (0, "")
        record("kill -9 / Ctrl-C during a campaign, then catalog rebuild", code, err, lost)
    for limit in (500, 3000, 20000):
        out = os.path.join(tmp, "full%d" % limit)
        code, err = run(["campaign", "--rig", os.path.join(here, "config", "sim.toml"), "--shots",
                         "3", "--out", out], tmp, prefix="ulimit -f %d; " % limit)
        record("disk full mid-write (file size limit)", code, err)
    out = os.path.join(tmp, "same")
    for seed in (1, 2, 3):
        run(["campaign", "--rig", os.path.join(here, "config", "sim.toml"), "--shots", "2", "--out",
             out, "--seed", str(seed)], tmp)
    kept = len([f for f in os.listdir(out) if f.endswith(".h5")])
    record("three campaigns into one folder (6 shots)", 0 if kept == 6 else 1,
           "" if kept == 6 else "kept %d" % kept, kept != 6)


with tempfile.TemporaryDirectory() as tmp:
    broken_profiles(tmp)
    corrupted_shots(tmp)
    interrupted(tmp)

total = [0, 0, 0, 0, 0]
print("| what was tried | cases | clear error (exit 1/2 + message) | ran fine (exit 0) | crashes, hangs, silent failures | data lost |")
print("|---|---|---|---|---|---|")
for family, r in results.items():
    print("| %s | %d | %d | %d | %d | %d |" % (family, r[0], r[1], r[2], r[3], r[4]))
    for i in range(5):
        total[i] += r[i]
print("| **all** | %d | %d | %d | %d | %d |" % tuple(total))
for family, r in results.items():
    for line in r[5][:3]:
        print("  crash in %s: %s" % (family, line), file=sys.stderr)
