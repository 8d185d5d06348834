"""The inline commands of the README and of the documentation's pages (issues 19, 28): rig's own
parser accepts every backticked ``rig ...`` outside the sh blocks, its option names exactly as
written (a synopsis through its concrete forms, a command elided with ``...`` through the forms
given in ELIDED). Each whole command is run here in a fresh folder beside the examples, with the
claims the pages make next to it checked (RUN), run in the ``slow`` tier (SLOW), or named with the
reason it is not (NOT_RUN); a command or option only named in prose is in MENTIONS. A new span must
be given one of these, and a name no span has any more is an error too."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import json
import pathlib
import re
import shlex
import subprocess
from collections.abc import Callable
from decimal import Decimal
from importlib.metadata import version
from typing import Any

import pytest

from rig.cli import build_parser
from rig.cli.common import UsageError
from rig.config import FaultsConfig, load_config
from rig.emulator.spawn import spawn_rig, stop_rig
from tests.test_readme import DOCS, ROOT, run_here, where

#: the README and the documentation's pages, one after the other: a figure is checked on whichever
#: page holds it (the README first)
README = "\n".join(path.read_text() for path in DOCS)
FLAT = " ".join(README.split())  #: the pages' prose with their line breaks as spaces

Check = Callable[[subprocess.CompletedProcess[str], pathlib.Path], None]


def spans() -> list[tuple[str, str]]:
    """(where: file and line, text) of every inline code span that starts with ``rig``, outside
    fenced blocks, in the README and the documentation's pages (``DOCS``); its whitespace as one
    space and a table's ``\\|`` as ``|``."""
    found = []
    for path in DOCS:
        text = path.read_text()
        body = re.sub(r"^```.*?^```", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.M | re.S)
        for m in re.finditer(r"(?<!`)`([^`]+)`(?!`)", body):
            span = " ".join(m.group(1).replace("\\|", "|").split())
            if span == "rig" or span.startswith("rig "):
                found.append((f"{where(path)} line {body[: m.start()].count(chr(10)) + 1}", span))
    return found


# --- synopses: [optional], (required), A|B, a placeholder in capitals, `...` ------------------

#: what a synopsis's placeholder stands for in its concrete forms (only parsed, never run)
PLACEHOLDERS = {
    "A": "16",
    "ACTION": "status",
    "B": "680",
    "C": "vcan0",
    "DEVICE": "epos4",
    "DIR": "figures",
    "FILE": "examples/dc_servo_position.toml",
    "H": "16",
    "HZ": "5",
    "I": "socketcan",
    "L": "-15",
    "N": "1",
    "NAME": "dc-servo",
    "P": "29536",
    "PRESET": "dc-servo",
    "RUN_DIR": "runs/identify",
    "S": "1",
    "T": "0.0004",
    "U": "1",
    "VALUE": "1",
    "W": "100",
    "ADDRESS": "tcp://127.0.0.1:8786",
    "LSS_ACTION": "inquire",
}
PLACEHOLDER = re.compile(r"^[A-Z][A-Z_]*$")

#: a span with `...` for what it leaves out: the whole command lines it stands for
ELIDED = {
    "rig ... | head": ["rig design dtsm --a-m 16 --b-m 680 --period 0.4e-3 --lam -15"],
    "rig run ... --fault NAME=VALUE": [
        "rig run --config examples/dc_servo_position.toml --emulate --fault frame_loss=0.01",
        "rig run --config examples/dc_servo_position.toml --fault law_nan_at=0.3",
    ],
    "rig drive ... jog|move|home --live": [
        "rig drive --emulate epos4 jog 10 --for 1 --live",
        "rig drive --emulate epos4 move 1 --live=terminal",
        "rig drive --emulate epos4 home --live=window",
    ],
    "rig drive --emulate epos4 ...": [
        "rig drive --emulate epos4 status",
        "rig drive --emulate epos4 enable",
        "rig drive --emulate epos4 sdo read 0x1018:1",
        "rig drive --emulate epos4 sdo write 0x6060 3",
        "rig drive --emulate epos4 jog 10 --for 1 --max-speed 20",
        "rig drive --emulate epos4 home --method 35",
        "rig drive --emulate epos4 move 1 --max-travel 2",
        "rig drive --emulate epos4 reset",
        "rig drive --emulate epos4 disable",
    ],
    "rig run --config ...": ["rig run --config my_rig.toml"],
    "rig view FOLDER ...": ["rig view runs sweeps"],
    "rig lss ... --select ADDRESS node-id 5 --store": [
        "rig lss --interface socketcan --channel can0 --select 0xFB:0x65520000:0x10000:1 node-id 5 --store"
    ],
    "rig lss ... bitrate 500 --store": ["rig lss --interface socketcan --channel can0 bitrate 500 --store"],
    "rig lss --emulate epos4 ...": ["rig lss --emulate epos4 inquire", "rig lss --emulate epos4 bitrate 500"],
}


def _tokens(text: str) -> list[str]:
    """Words and the brackets, parentheses and spaced bars between them; ``--x[=a|b]`` becomes
    the one word ``--x|--x=a|--x=b``."""
    text = re.sub(
        r"(--[\w-]+)\[=([^\]\s]+)\]",
        lambda m: "|".join([m[1], *(f"{m[1]}={v}" for v in m[2].split("|"))]),
        text,
    )
    return re.sub(r"([\[\]()])", r" \1 ", text).split()


Seq = list[Any]  #: words (``a|b`` a choice of words) and (bracket, alternatives) groups


def _group(tokens: list[str], i: int = 0, close: str | None = None) -> tuple[list[Seq], int]:
    alts: list[Seq] = [[]]
    while i < len(tokens):
        tok, i = tokens[i], i + 1
        if tok == close:
            return alts, i
        if tok in ("[", "("):
            inner, i = _group(tokens, i, "]" if tok == "[" else ")")
            alts[-1].append((tok, inner))
        elif tok == "|":
            alts.append([])
        elif tok != "...":  # a repetition: `[--param NAME=VALUE ...]`
            alts[-1].append(tok)
    assert close is None, f"no {close!r}"
    return alts, i


def _width(alts: list[Seq]) -> int:
    """The most choices of any one alternation."""
    return max(
        [len(alts)]
        + [
            _width(node[1]) if isinstance(node, tuple) else len(node.split("|"))
            for seq in alts
            for node in seq
        ]
    )


def _concrete(word: str) -> str:
    parts = word.split("=")
    for part in parts:
        assert not PLACEHOLDER.match(part) or part in PLACEHOLDERS, f"placeholder {part} not in PLACEHOLDERS"
    return "=".join(PLACEHOLDERS.get(p, p) for p in parts)


def _expand(alts: list[Seq], k: int, full: bool) -> list[str]:
    out: list[str] = []
    for node in alts[k % len(alts)]:
        if isinstance(node, str):
            choices = node.split("|")
            out.append(_concrete(choices[k % len(choices)]))
        elif node[0] == "(" or full:
            out += _expand(node[1], k, full)
    return out


def is_synopsis(text: str) -> bool:
    return any(c in text for c in "[]()|") or any(
        PLACEHOLDER.match(part) for tok in text.split() for part in re.split(r"[=|]", tok)
    )


def forms(text: str) -> list[str]:
    """The concrete command lines of a synopsis: every choice of every alternation at least once,
    with every optional part and with none. ``rig SUB`` stays outside a top-level alternation."""
    if text in ELIDED:
        return ELIDED[text]
    words = text.split()
    n = next(
        (i for i, w in enumerate(words) if w.startswith("-") or not re.fullmatch(r"[a-z-]+", w)), len(words)
    )
    head, (alts, _) = words[:n], _group(_tokens(" ".join(words[n:])))
    return sorted(
        {" ".join(head + _expand(alts, k, full)) for k in range(_width(alts)) for full in (True, False)}
    )


# --- rig's parser, exactly (no abbreviations) ------------------------------------------------


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """``parser`` and every subparser below it."""
    found = [parser]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                found += _parsers(child)
    return found


@pytest.fixture(scope="module")
def parser() -> argparse.ArgumentParser:
    root = build_parser()
    for p in _parsers(root):
        p.allow_abbrev = False  # `--error` for `--error-space` would pass otherwise
    return root


def refusal(parser: argparse.ArgumentParser, line: str) -> str | None:
    """Why rig's parser refuses the command line ``line``, or None when it accepts it."""
    argv = shlex.split(line)
    assert argv[0] == "rig", line
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            parser.parse_args(argv[1:])
    except UsageError as exc:
        return str(exc)
    except SystemExit as exc:  # --version, --help
        return None if exc.code == 0 else f"exit {exc.code}"
    return None


def unknown_names(parser: argparse.ArgumentParser, text: str) -> list[str]:
    """The subcommand and options of a mention that rig has not: its first word after ``rig``
    must be a subcommand and each option one of that subcommand's (or of one below it)."""
    words = text.split()[1:]
    subs = {
        n: p
        for a in parser._actions
        if isinstance(a, argparse._SubParsersAction)
        for n, p in a.choices.items()
    }
    known = set(parser._option_string_actions)
    commands = [w for w in words if not w.startswith("-")]
    bad = [commands[0]] if commands and commands[0] not in subs else []
    if commands and not bad:
        known |= {o for p in _parsers(subs[commands[0]]) for o in p._option_string_actions}
    return bad + [w for w in words if w.startswith("-") and w.split("=")[0] not in known]


# --- what the README says ------------------------------------------------------------------


def said(pattern: str) -> re.Match[str]:
    """Where the pages' prose (line breaks as spaces) matches ``pattern``, in which ``(N)`` is a
    number; fails when it does not."""
    match = re.search(pattern.replace("(N)", r"(\d+(?:\.\d+)?)"), FLAT)
    assert match, f"neither the README nor docs/*.md says {pattern!r} any more: update this test with it"
    return match


def table(header: str) -> list[list[str]]:
    """The body rows' cells of the table (on the README or a page of docs/) whose header row starts
    with ``header``."""
    lines = README.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]])
    return rows


def agree(a: str, b: str | float) -> bool:
    """Two printed figures agree to the coarser one's last digit (half a unit of it)."""
    ulps = [Decimal(5).scaleb(Decimal(s).as_tuple().exponent - 1) for s in (a, str(b)) if isinstance(s, str)]
    if isinstance(b, float):
        ulps.append(Decimal("1e-12"))
    return abs(Decimal(a) - Decimal(str(b))) <= max(ulps)


def run_dir(folder: pathlib.Path, name: str) -> pathlib.Path:
    (found,) = (folder / "runs").glob(f"{name}-*")
    return found


# --- the checks of the commands run here -----------------------------------------------------


def _version(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    said(r"`rig --version` says which rig this is")
    assert proc.stdout == f"rig {version('drive-rig')}\n"


def _design(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    out = json.loads(proc.stdout)
    keys = re.findall(r"`(\w+)`", said(r"`--json` prints (`A_delta`.*?`c_delta_A_delta`)")[1])
    assert len(keys) == 6 and set(keys) <= set(out), (keys, out)
    c, ca = said(r"reproduces \(7\.31\): `c_delta = \[(.*?)\]`, `c_delta A_delta = \[(.*?)\]`").groups()
    a, b = said(r"gives A_delta = \[(.*?)\], b_delta = \[(.*?)\]").groups()
    printed = {"c_delta": c, "c_delta_A_delta": ca, "A_delta": a.replace(";", ","), "b_delta": b}
    for key, text in printed.items():
        values = re.findall(r"-?[\d.]+", text)
        got = [float(v) for v in ([v for row in out[key] for v in row] if key == "A_delta" else out[key])]
        assert len(values) == len(got) and all(map(agree, values, got)), (key, text, got)


def _zoo(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    names = sorted(row[0].strip("`") for row in table("| profile | what it tries on a host |"))
    assert sorted(line.split()[0] for line in proc.stdout.splitlines()) == names


def _dismc(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    printed = {line.split()[0]: line.split()[1:] for line in proc.stdout.splitlines()[2:6]}
    for name, rise, settling, u_min, u_max, _paper in table("| controller | rise s | settling s |"):
        got = printed[name]
        assert agree(rise, got[0]) and agree(u_min, got[2]) and agree(u_max, got[3]), (name, got)
        assert agree(settling, got[1]) if got[1] != "-" else "does not settle" in settling, (name, got)


def _dq(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = [line.split() for line in proc.stdout.splitlines()]
    by = {tuple(r[:3]): r[3:9] for r in rows if len(r) > 9 and r[1] in ("plant", "beta1=1")}
    for gamma, *figures, _printed in table("| gamma | bw/f_s | GM dB |"):  # Table II
        for strategy in ("s-pwm-start", "a-pwm-double"):
            got = by[(strategy, "plant", gamma)]
            assert all(map(agree, figures, got)), (strategy, gamma, figures, got)
    overshoot, settling = said(
        r"With beta_1 = 1: overshoot ([\d./]+) % and settling ([\d/]+) samples"
    ).groups()
    for gamma, os_, settle in zip(
        ("0.20", "0.25", "0.30", "0.35"), overshoot.split("/"), settling.split("/")
    ):
        got = by[("s-pwm-middle", "beta1=1", gamma)]  # Table III
        assert agree(os_, got[3]) and settle == got[5], (gamma, got)
    peaks = {(r[0], r[3], r[6]): r[7] for r in rows if len(r) == 8 and r[1] == "w_k/w_s"}
    for strategy, ratio, *laws in table("| strategy | ratio | proposed |"):
        for law, figure in zip(("proposed", "pi", "pi-decoupled"), laws):
            got = peaks[(strategy.lower(), ratio, law)]
            assert agree(figure.split()[0], got), (strategy, ratio, law, figure, got)


def _servo_run(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    where = run_dir(folder, "dc-servo-position")
    files = said(r"--emulate` writes `runs/<name>-<time>/` with (.*?)\. Every way out")[1]
    for name in re.findall(r"`(\w+\.(?:json|csv|mat|asc|png))`", files):
        assert (where / name).is_file(), name
    summary = json.loads((where / "summary.json").read_text())
    keys = said(r"`--json` prints the summary \((.*?)\); exit code 3")[1]
    top, per_axis = keys.split("`axes`: per axis")
    assert set(re.findall(r"`(\w+)`", top)) <= set(summary), summary.keys()
    assert set(re.findall(r"`(\w+)`", per_axis)) <= set(summary["axes"]["motor"])
    count, rms, threshold, share = said(
        r"over its 3 s, second half: \(7\.30\) (\d+) alternations?, du RMS (N) V, "
        r"threshold (N) V, (N) % sign law"
    ).groups()
    assert summary["chattering_count"] == int(count) and agree(rms, summary["chattering_amplitude"])
    assert agree(threshold, summary["chattering_threshold"]) and agree(share, 100 * summary["sign_law_share"])
    assert agree(said(r"the in-process result exactly \(rms (N) mrad")[1], 1e3 * summary["rms_error"])
    assert summary["safe_stop_reason"] is None and summary["stop_confirmed"] is True
    assert f"run directory   runs/{where.name}" in proc.stdout
    # "the same with `law = "sign"` in `[controller]`": a copy of the example so
    count, rms, share = said(
        r"the same with `law = \"sign\"` in `\[controller\]`: (N), (N) V, (N) % sign law"
    ).groups()
    example = (ROOT / "examples/dc_servo_position.toml").read_text()
    (folder / "sign.toml").write_text(example.replace("[controller]\n", '[controller]\nlaw = "sign"\n', 1))
    sign = json.loads(run_here("rig run --config sign.toml --emulate --json", folder, link=False).stdout)
    assert sign["chattering_count"] == int(count) and agree(rms, sign["chattering_amplitude"]), sign
    assert agree(share, 100 * sign["sign_law_share"])


def _idtsm_run(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """docs/chattering.md: the IDTSM example's torque limit-cycles between its limits, counted."""
    summary = json.loads((run_dir(folder, "im-speed-idtsm") / "summary.json").read_text())
    count, rms, share = said(
        r"examples/im_speed_idtsm\.toml --emulate`: the IDTSM's torque limit-cycles between its \+-10 N m "
        r"limits, (N) alternations, du RMS (N) N m, (N) % of the second half at a bound"
    ).groups()
    assert summary["chattering_count"] == int(count) and agree(rms, summary["chattering_amplitude"])
    assert agree(share, 100 * summary["sign_law_share"])


def _identify(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    a_m, b_m = said(r"--param plant\.b_m=412` gives a_m = (N) and b_m = (N)").groups()
    where = run_dir(folder, "identify-voltage")
    assert re.search(rf"written to runs/{where.name}/identification\.json", proc.stdout), proc.stdout
    result = json.loads((where / "identification.json").read_text())
    assert agree(a_m, result["a_m"]) and agree(b_m, result["b_m"]), result


def _live(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    said(r"`rig run --config examples/dyno_speed_load.toml --emulate --live` shows each axis's reference")
    axes = [axis.name for axis in load_config(ROOT / "examples/dyno_speed_load.toml").axes]
    last = proc.stderr.rsplit("live  t = ", 1)[1].splitlines()[1:]  # the last values, at the end
    assert [line.split()[0] for line in last[: len(axes)]] == axes, proc.stderr[-2000:]
    assert all(("ref" in line and "meas" in line and "cmd" in line) for line in last[: len(axes)])
    assert all(unit in proc.stderr for unit in ("rad/s", "N m", " V")), proc.stderr[-2000:]


#: the whole commands run in the default pass (each a few seconds), with their claims' checks
RUN: dict[str, Check] = {
    "rig --version": _version,
    "rig design dtsm --a-m 16 --b-m 680 --period 0.4e-3 --lam -15 --error-space --json": _design,
    "rig emulate --list": _zoo,
    "rig reproduce dismc": _dismc,
    "rig reproduce dq-current": _dq,
    "rig run --config examples/dc_servo_position.toml --emulate": _servo_run,
    "rig run --config examples/im_speed_idtsm.toml --emulate": _idtsm_run,
    "rig run --config examples/dyno_speed_load.toml --emulate --live": _live,
}


def _drives(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = {}
    for line in proc.stdout.splitlines():  # name [bus] figures: the first row of each name and bus
        m = re.match(r"\s+(.*?)\s+(no|yes)?\s*(-?[\d.e+-]+(?:\s+-?[\d.e+-]+)+)$", line)
        if m:
            rows.setdefault((m[1], m[2]), m[3].split())
    for law, simulated, theory in table("| law | simulated rad/s | theory rad/s |"):  # Figs. 9-10
        name = law.replace("+ (6", "DTSM + (6").replace(", alpha = ", " alpha=").split(",")[0]
        got = rows[(name, None)]
        assert agree(simulated, got[0]) and agree(theory, got[1]), (law, got)
    pure, bus = said(r"rms error over the run (N) mrad pure / (N) mrad over the bus").groups()
    assert agree(pure, 1e3 * float(rows[("(7.30) h=16", "no")][0]))
    assert agree(bus, 1e3 * float(rows[("(7.30) h=16", "yes")][0]))
    for law, max_e, rms_e, _ss in table("| law | max \\|e\\| pure / dyno |"):  # VII.C
        name = "IDTSM (6.20)-(6.21), Table IV" if law.startswith("IDTSM") else law
        for on_bus, m, r in zip(("no", "yes"), max_e.split(" / "), rms_e.split(" / ")):
            got = rows[(name, on_bus)]
            assert agree(r, got[0]) and agree(m, got[1]), (law, on_bus, got)
    figures = said(r"max position error (N) rad pure / (N) rad on the dyno .*? rms (N) / (N) rad")
    for on_bus, m, r in (("no", figures[1], figures[3]), ("yes", figures[2], figures[4])):
        got = rows[("cascade (6.36*), Table V", on_bus)]
        assert agree(r, got[0]) and agree(m, got[1]), (on_bus, got)


def _faults(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = {line.split()[0]: line.split(None, 6)[1:] for line in proc.stdout.splitlines()[1:]}
    for scenario, detected, disabled, lost, speed, confirmed, message in table("| scenario | detected after"):
        got = rows[scenario]
        if scenario == "modbus-timeout":
            break  # lock-step rows above; the Modbus and cross-process rows are wall-clock runs
        assert got[0] == detected.split()[0] and (got[1] == "True") == disabled.startswith("yes"), got
        assert got[2] == lost and agree(speed.split()[0], got[3]), got
        assert (got[4] == "True") == confirmed.startswith("yes") and got[5] == message, (got, message)


def _benchmarks(plant: bool) -> Check:
    def check(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
        names = {
            row[0].split()[0] for row in table("| benchmark | us/step |") if ("(plant)" in row[0]) == plant
        }
        assert names <= {line.split()[0] for line in proc.stdout.splitlines()}, proc.stdout

    return check


def _physics(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    got = {line.split()[0] for line in proc.stdout.splitlines()}
    for row in table("| preset | physics steps/s |"):
        preset = row[0].split()[0]
        assert {f"{preset}_physics_steps_per_s", f"{preset}_lockstep_cycles_per_s"} <= got, (preset, got)


def _loop(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    names = {re.sub(r"`(\w+)`.*", r"\1", row[0]) for row in table("| figure | runs | goal |")}
    assert names <= {line.split()[0] for line in proc.stdout.splitlines()}, proc.stdout


def _identify_bench(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    got = {line.split()[0]: line.split()[1] for line in proc.stdout.splitlines()}
    for figure, a_m, b_m in table("| figure | a_m | b_m |"):
        kind = figure.split()[0]  # mean, worst
        for name, text in (("a_m", a_m), ("b_m", b_m)):
            assert agree(text.rstrip(" %"), got[f"identify_{name}_{kind}_abs_error"]), (figure, name, got)


def _scan(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    said(r"\| the CANopen nodes on a bus: node id, NMT state, device type, profile \(")
    said(r"vendor and its name from CiA's vendor-ID list")
    header, *rows = proc.stdout.splitlines()
    assert header.split() == [
        "node",
        "NMT",
        "state",
        "device",
        "type",
        "profile",
        "vendor",
        "vendor",
        "name",
        "product",
    ]
    assert [row.split()[0] for row in rows] == ["1", "2"], proc.stdout  # drive and encoder


def _json_keys(pattern: str) -> Check:
    """A check that the JSON on stdout (its first element, if a list) has the keys the README
    names in the backticks or quotes of ``pattern``'s group."""

    def check(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
        out = json.loads(proc.stdout)
        keys = set(re.findall(r'[`"](\w+)[`"]', said(pattern)[1]))
        assert len(keys) >= 2 and keys <= set(out[0] if isinstance(out, list) else out), (keys, out)

    return check


def _drive(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    """status says the state and mode by name, identity, statusword bits, 0x603F and the last EMCY
    in words, units and the PDO mapping as a table; a jog's report ends at rest and disabled, its
    stop confirmed."""
    said(r"status` writes nothing and needs no factor: it says its state and mode by name, its identity")
    said(r"end, as Ctrl-C does, with the drive's quick-stop ramp to rest and then disable")
    status, _, jog = proc.stdout.partition("PDO mapping in force:")
    rows = {line[:15].strip(): line[16:] for line in status.splitlines()}
    for key in ("state", "mode", "identity", "error code", "last EMCY", "position unit", "velocity unit"):
        assert key in rows, key
    assert rows["identity"].startswith("vendor 0x000000FB (maxon motor ag) / product 0x")
    assert "RPDO1  0x201" in jog and "0x603F = 0x0000, no error" in proc.stdout
    assert "statusword bits:" in jog and "  bit 12" in jog  # every bit, named
    lines = {line[:15].strip(): line[16:] for line in jog.splitlines() if line.strip() and line[0] != " "}
    assert lines["result"] == "done" and lines["asked"] == "10 rad/s"  # the jog's report, printed last
    assert lines["stop"] == "at rest and disabled (SWITCH ON DISABLED); the stop confirmed"


#: synopses (and an elided command) run in the default pass in a concrete form, with the claims
#: next to them checked
INSTANCES: dict[str, tuple[str, Check]] = {
    "rig scan (--interface I --channel C [--bitrate B] | --emulate NAME) [--sdo-timeout S] [--json]": (
        "rig scan --emulate dc-servo",
        _scan,
    ),
    "rig drive --emulate epos4 ...": (
        "rig drive --emulate epos4 status && rig drive --emulate epos4 jog 10 --for 1",
        _drive,
    ),
    "rig faults [--json] [--scenario NAME ...]": (
        "rig faults --json --scenario tpdo-stall",
        _json_keys(r"`--json` prints a list of `\{(.*?)\}`"),
    ),
    "rig reproduce dq-current [--json] [--plot DIR] [--param NAME=VALUE ...]": (
        "rig reproduce dq-current --json",
        _json_keys(r"`--json` prints `\{(\"tables\": \[\.\.\.\], \"cross_coupling\": \[\.\.\.\])\}`"),
    ),
    "rig identify (--config FILE | --emulate NAME | --from-log RUN_DIR) [--param NAME=VALUE ...] "
    "[--input voltage|torque] [--excitation prbs|steps|chirp|multisine|friction] [--duration S] [--f-min HZ] "
    "[--f-max HZ] [--seed N] [--u0 U] [--amplitude U] [--clock S] [--loop-model FILE|RUN_DIR] "
    "[--loop-bandwidth HZ] [--speed W] [--json] [--plot DIR]": (
        "rig identify --emulate dc-servo --json",
        _json_keys(r"`--json` prints (`a_m`, `b_m`, .*?`run_dir`)"),
    ),
}


def _sweep_rows(folder: pathlib.Path, name: str) -> dict[tuple[str, float], dict[str, Any]]:
    """The rows of the sweep ``name`` run in ``folder``, by (controller, the other parameter)."""
    import pyarrow.parquet as pq

    rows = pq.read_table(folder / "sweeps" / name / "results.parquet").to_pylist()
    assert rows and all(r["error"] is None for r in rows if "controller" in r), rows[:1]
    return {(r["controller"], r["u_bound" if "u_bound" in r else "L_error"]): r for r in rows}


def _near(rows: dict[tuple[str, float], dict[str, Any]], controller: str, text: str) -> dict[str, Any]:
    """The row of ``controller`` whose parameter is ``text`` (or the one printed to its last digit)."""
    if (controller, float(text)) in rows:
        return rows[(controller, float(text))]
    (row,) = [r for (c, x), r in rows.items() if c == controller and agree(text, x)]
    return row


def _dismc_sweep(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = _sweep_rows(folder, "dismc-anti-windup")
    m = said(
        r"DISMC-LQR diverges for every bound up to (N) \(rms error (N)-(N)\) and tracks from (N) on "
        r"\(rms (N)\); DISMC-AW-LQR tracks down to a bound of (N) \(rms (N)\) and diverges only below (N),"
    )
    up_to, low, high, tracks, rms, aw_down, aw_rms, aw_below = m.groups()
    lqr = sorted((x, r["rms_error"]) for (c, x), r in rows.items() if c == "DISMC-LQR")
    aw = sorted((x, r["rms_error"]) for (c, x), r in rows.items() if c == "DISMC-AW-LQR")
    diverged, tracked = [x for x, e in lqr if e > 1.0], [x for x, e in lqr if e < 1.0]
    assert agree(up_to, max(diverged)) and agree(tracks, min(tracked))
    errors = [e for _, e in lqr if e > 1.0]
    assert agree(low, min(errors)) and agree(high, max(errors))
    assert agree(rms, _near(rows, "DISMC-LQR", tracks)["rms_error"])
    assert agree(aw_down, min(x for x, e in aw if e < 1.0))
    assert agree(aw_below, max(x for x, e in aw if e > 1.0))
    assert agree(aw_rms, _near(rows, "DISMC-AW-LQR", aw_down)["rms_error"])
    assert (folder / "figures" / "dismc-anti-windup-rms_error.png").is_file()


def _dq_sweep(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = _sweep_rows(folder, "dq-L-error")
    m = said(
        r"its cross-coupling peak stays at most (N) per unit of the q step for L from -50 % to \+100 % "
        r"of the true one \(0 at the true L\), against (N)-(N) for the PI, and (N) for the decoupled PI "
        r"at the true L, which grows to (N) at \+75 % and is unstable at \+100 % \(peak (N)\)"
    )
    proposed, pi_low, pi_high, dec0, dec75, dec100 = m.groups()
    peaks = {c: [r["peak_id"] for (c_, _), r in rows.items() if c_ == c] for c in ("proposed", "pi")}
    assert agree(proposed, max(peaks["proposed"])) and _near(rows, "proposed", "0")["peak_id"] < 1e-9
    assert agree(pi_low, min(peaks["pi"])) and agree(pi_high, max(peaks["pi"]))
    for text, x in ((dec0, "0"), (dec75, "0.75"), (dec100, "1")):
        assert agree(text, _near(rows, "pi-decoupled", x)["peak_id"]), (text, x)


def _servo_sweep(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    import pyarrow.parquet as pq

    rows = pq.read_table(folder / "sweeps" / "servo-b_m" / "results.parquet").to_pylist()
    at = {(r["emulator.params.b_m"], r["emulator.params.period"]): r for r in rows}
    assert len(rows) == 45 and all(r["stop_confirmed"] for r in rows)
    m = said(
        r"tracks plants of 0\.25 to (N) times that b_m at its period with an rms error of (N)-(N) mrad, "
        r"and of 4 times with (N) mrad; .*? (N) or (N) alternations from 0\.25 to 1 times, (N) at twice, "
        r"(N) at 2\.83 times and (N) at 4 times, with a sign-law share of 0 up to twice and (N) % at 4 "
        r"times\. The plots draw the linear edge at each period .*?: (N), (N), (N), (N) and (N) times the "
        r"design's b_m at 0\.1, 0\.2, 0\.4, 1 and 2 ms\. At 0\.1 ms the count goes from (N) at twice the "
        r"b_m to (N) at 2\.83 times, across the edge, and the rms error stays below (N) mrad over the "
        r"whole range\. .*? at 2 ms the rms error at the design's own b_m is (N) mrad and the command "
        r"alternates (N) times there, (N) at twice the b_m; at 1 ms (N) times at twice\. The points of "
        r"2\.83 and 4 times at 1 and 2 ms run to their end, far from tracking: an rms error of (N) and (N) "
        r"mrad at 1 ms, (N) and (N) mrad at 2 ms, with (N) and (N), (N) and (N) alternations"
    )
    times, low, high, rms4, few, many, c2, c283, c4, share4, *edges, fast2, fast283, below = m.groups()[:18]
    rms2ms, slow1, slow2, mid2 = m.groups()[18:22]
    edge_rms, edge_counts = m.groups()[22:26], m.groups()[26:30]
    quiet = {b: r for (b, t), r in at.items() if t == 4e-4}
    below4 = [r["rms_error"] for b, r in quiet.items() if b < 2720.0]
    assert agree(times, max(b for b in quiet if b < 2720.0) / 680.0)
    assert agree(low, 1e3 * min(below4)) and agree(high, 1e3 * max(below4))
    assert agree(rms4, 1e3 * quiet[2720.0]["rms_error"]) and agree(
        share4, 100 * quiet[2720.0]["sign_law_share"]
    )
    assert {r["chattering_count"] for b, r in quiet.items() if b <= 680.0} <= {float(few), float(many)}
    assert all(r["sign_law_share"] == 0.0 for b, r in quiet.items() if b <= 1360.0)
    for text, b in ((c2, 1360.0), (c283, 1923.3), (c4, 2720.0)):
        assert agree(text, _near_b(quiet, b)["chattering_count"]), (text, b)
    from rig.sweep.edges import b_m_edges
    from rig.sweep.load import load_spec

    computed = b_m_edges(load_spec(ROOT / "examples/sweeps/servo_b_m.toml"), rows)
    for text, period in zip(edges, (1e-4, 2e-4, 4e-4, 1e-3, 2e-3)):
        assert agree(text, computed[(("emulator.params.period", period),)] / 680.0), (text, period)
    fast = {b: r for (b, t), r in at.items() if t == 1e-4}
    assert 1e3 * max(r["rms_error"] for r in fast.values()) < float(below)
    assert agree(fast2, fast[1360.0]["chattering_count"]) and agree(
        fast283, _near_b(fast, 1923.3)["chattering_count"]
    )
    slow = {b: r for (b, t), r in at.items() if t == 2e-3}
    assert agree(rms2ms, 1e3 * slow[680.0]["rms_error"]) and agree(slow1, slow[680.0]["chattering_count"])
    assert agree(slow2, slow[1360.0]["chattering_count"])
    assert agree(mid2, at[(1360.0, 1e-3)]["chattering_count"])
    assert all(r["status"] == "completed" for r in rows), [k for k in at if at[k]["status"] != "completed"]
    for i, (t, b) in enumerate((t, b) for t in (1e-3, 2e-3) for b in (1923.3, 2720.0)):
        row = _near_b({b_: r for (b_, t_), r in at.items() if t_ == t}, b)
        assert agree(edge_rms[i], 1e3 * row["rms_error"]) and agree(edge_counts[i], row["chattering_count"])


def _edge_rows(folder: pathlib.Path, name: str) -> dict[float, dict[str, Any]]:
    import pyarrow.parquet as pq

    rows = pq.read_table(folder / "sweeps" / name / "results.parquet").to_pylist()
    assert all(r["status"] == "completed" and r["stop_confirmed"] for r in rows)
    return {round(r["emulator.params.b_m"] / 680.0, 2): r for r in rows}


def _edge_sweep(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = _edge_rows(folder, "servo-edge")
    edge, b_m, count, rms_low, rms_high = said(
        r"put the edge at (N) times 680, b_m = (N), drawn on the plots\. .*? from 2\.1 times on it has "
        r"(N) \(every increment .*? the rms error from (N) mrad at 1\.9 times to (N) mrad at 2\.1 times"
    ).groups()
    below, above = [r for k, r in rows.items() if k < 2.0], [r for k, r in rows.items() if k > 2.0]
    assert min(rows) == 0.5 and all(r["chattering_count"] == 0 and r["sign_law_share"] == 0 for r in below)
    assert all(r["chattering_count"] == int(count) and r["sign_law_share"] == 1.0 for r in above)
    assert agree(rms_low, 1e3 * rows[1.9]["rms_error"]) and agree(rms_high, 1e3 * rows[2.1]["rms_error"])
    from rig.sweep.edges import b_m_edges
    from rig.sweep.load import load_spec

    (computed,) = b_m_edges(load_spec(ROOT / "examples/sweeps/servo_edge.toml"), list(rows.values())).values()
    assert agree(edge, computed / 680.0) and agree(b_m, computed)
    assert (folder / "figures" / "servo-edge-chattering_count.png").is_file()


def _edge_lag_sweep(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
    rows = _edge_rows(folder, "servo-edge-lag")
    m = said(
        r"move the edge to (N) times, b_m = (N)\. The count grows towards it, (N) alternations at twice the "
        r"design's b_m, (N) at 3 times, (N) at 3\.6 times, and jumps to (N) at 3\.8 times, with the rms "
        r"error from (N) to (N) mrad and the sign-law share from (N) % to (N) % \((N) % at 4 times\)"
    )
    edge, b_m, c2, c3, c36, c38, rms36, rms38, s36, s38, s4 = m.groups()
    for text, k in ((c2, 2.0), (c3, 3.0), (c36, 3.6), (c38, 3.8)):
        assert agree(text, rows[k]["chattering_count"]), (text, k)
    assert agree(rms36, 1e3 * rows[3.6]["rms_error"]) and agree(rms38, 1e3 * rows[3.8]["rms_error"])
    for text, k in ((s36, 3.6), (s38, 3.8), (s4, 4.0)):
        assert agree(text, 100 * rows[k]["sign_law_share"]), (text, k)
    from rig.sweep.edges import b_m_edges
    from rig.sweep.load import load_spec

    (computed,) = b_m_edges(
        load_spec(ROOT / "examples/sweeps/servo_edge_lag.toml"), list(rows.values())
    ).values()
    assert agree(edge, computed / 680.0) and agree(b_m, computed)


def _near_b(rows: dict[float, dict[str, Any]], b_m: float) -> dict[str, Any]:
    """The row whose b_m is nearest ``b_m`` (the grid's 1923.3 is printed to five digits)."""
    return rows[min(rows, key=lambda b: abs(b - b_m))]


def _figures_named(header: str) -> Check:
    """The figures a README table names (its first column's first backticked word) are printed."""

    def check(proc: subprocess.CompletedProcess[str], folder: pathlib.Path) -> None:
        names = {re.sub(r"`(\S+)`.*", r"\1", row[0]) for row in table(header)}
        assert names <= {line.split()[0] for line in proc.stdout.splitlines()}, (names, proc.stdout)

    return check


def _doctor(proc: subprocess.CompletedProcess[str]) -> None:
    """docs/time.md's rows: what the kernel gives, a verdict for the period, the changes."""
    keys = {line[:15].strip() for line in proc.stdout.splitlines()}
    assert {"kernel", "cpuidle", "SCHED_FIFO", "PM QoS", "period 400 us"} <= keys, proc.stdout


#: the whole commands that take half a minute or more: the ``slow`` tier (``-m slow``)
SLOW: dict[str, Check] = {
    "rig reproduce drives": _drives,
    "rig faults": _faults,
    "rig bench controllers": _benchmarks(plant=False),
    "rig bench plant": _benchmarks(plant=True),
    "rig bench physics": _physics,
    "rig bench identify": _identify_bench,
    "rig bench loop": _loop,
    "rig bench soak": lambda proc, folder: None,  # its figures are wall-clock and memory
    "rig bench stops": lambda proc, folder: None,
    "rig doctor --period 0.0004": lambda proc, folder: _doctor(proc),
    "rig bench socketcand": lambda proc, folder: None,  # wall-clock figures
    "rig sweep examples/sweeps/dismc_anti_windup.toml --plot figures": _dismc_sweep,
    "rig sweep examples/sweeps/dq_L_error.toml --plot figures": _dq_sweep,
    "rig sweep examples/sweeps/servo_b_m.toml --plot figures": _servo_sweep,
    "rig sweep examples/sweeps/servo_edge.toml --plot figures": _edge_sweep,
    "rig sweep examples/sweeps/servo_edge_lag.toml --plot figures": _edge_lag_sweep,
    "rig bench sweep": _figures_named("| `rig bench sweep` figure"),
    "rig bench startup": _figures_named("| `rig bench startup` figure"),
    "rig bench memory": _figures_named("| `rig bench memory` figure"),
}

#: the whole commands not run here, and why (each is parsed)
NOT_RUN = {
    "rig demo": "the Quick start's ```sh block runs it (tests/test_readme.py)",
    "rig identify --emulate dc-servo --param plant.a_m=23.5 --param plant.b_m=412": "the ```sh block "
    "of docs/identification.md runs it as written and checks the a_m and b_m given here with "
    "_identify (tests/test_readme.py)",
    "rig scan --interface socketcan --channel can0 [--bitrate 500000]": "a real CAN bus (can0)",
    "rig drive --interface socketcan --channel can0 --node 1 --eds mydrive.eds status": "a real drive "
    "on can0 and the reader's EDS",
    "rig run --config my_rig.toml": "the reader's own rig",
    "rig emulate --eds mydrive.eds": "the reader's own EDS",
    "rig emulate --preset dc-servo --interface socketcan --channel vcan0": "root and a kernel with vcan "
    "(the vcan tier serves it so)",
    "rig emulate --preset dc-servo": "a server until Ctrl-C, for a client in another terminal: the "
    "timing tier runs it as written, with rig scan beside it (test_the_emulator_serves_two_nodes)",
    "rig emulate --preset dc-servo --time lockstep --param load=pulse:0.0346:1.5:3": "a server beside "
    "`rig run` in another terminal: the timing tier runs the two as written "
    "(test_a_run_against_the_emulator_in_another_process)",
    "rig lss --interface socketcan --channel can0 scan": "a real CAN bus (can0)",
    "rig emulate --device epos4 --node 255": "a server until Ctrl-C, for a client in another terminal "
    "(tests/rig/test_lss_processes.py serves it so, with rig lss beside it)",
    "rig emulate --device epos4": "a server until Ctrl-C, for a client in another terminal "
    "(tests/rig/test_zoo_runs.py and the timing tier's cross-process fault scenarios serve it so)",
    "rig emulate --modbus-map abb-drives-profile": "a server until Ctrl-C, for a client in another "
    "terminal (the interop tier's tests/interop/test_mbpoll.py serves it so)",
    "rig bench stops --period 0.001 --load 2": "20 real-time runs of 10 s under two busy processes "
    "(minutes, and it loads the machine): the slow tier runs rig bench stops",
    "rig bench stops --period 0.0004 --load 2": "as rig bench stops --period 0.001 --load 2",
    "rig bench stops --period 0.0004 --load 0 --load 2": (
        "as rig bench stops --period 0.001 --load 2 (two loads)"
    ),
    "rig bench stops --period 0.0004 --load 2 --runs 4 --seconds 5": (
        "as rig bench stops --period 0.001 --load 2 (four runs: the A/B of two commits)"
    ),
    "rig identify --emulate epos4 --input torque": (
        "tests/rig/test_identify_twins.py runs it on each CST twin"
    ),
    "rig identify --emulate epos4 --input torque --excitation multisine --f-min 10 --amplitude 0.05 "
    "--loop-model RUN_DIR": "needs the run directory of the command before it; "
    "tests/rig/test_identify_closed_loop.py runs it, shorter, on epos4 and kollmorgen-s300",
}

#: spans that only name a command or an option in prose: their names are checked, nothing is run
MENTIONS = {
    "rig",
    "rig -v",
    "rig --help",
    "rig emulate &",  # a script's background job (docs/cli.md: stop signals)
    "rig bench",
    "rig run",
    "rig scan",
    "rig identify",
    "rig drive",
    "rig lss",
    "rig doctor",
    "rig emulate",
    "rig run --config",
    "rig run --emulate",
    "rig run --reset-fault",
    "rig emulate --param",
    "rig emulate --port",
    "rig drive --json status",  # docs/cli.md: an option before or after the action
    "rig drive status --json",
    "rig emulate --rt-cpu 1",  # an experiment the benchmarks page reports (the emulator on the host's CPU)
    "rig drive sdo write",
    "rig emulate --device",
    "rig emulate --modbus-map",
    "rig identify --input torque",
    "rig identify --excitation multisine",
    "rig sweep",
    "rig sweep SPEC.toml",
    "rig emulate --rt-priority 0",
    "rig identify --excitation friction",
    "rig tune",
    "rig reproduce",
    "rig export",
    "rig design dtsm",
    "rig design dtsm --from-identify",
    "rig view",
    "rig run --view",
    "rig bench view",
    "rig bench view --runs 2 --seconds 5",  # the benchmarks page's figures: minutes of real-time runs
    "rig bench view --runs 5 --seconds 10",  # the same, an earlier quiet set the page gives
    "rig bench view --runs 8 --seconds 10",  # the same, the quiet set the page and docs/view.md give
}


def test_every_span_is_parsed_run_or_named() -> None:
    """Each concrete span has a place, and each name here is still a span of the README."""
    texts = {text for _, text in spans()}
    places = [set(RUN), set(SLOW), set(NOT_RUN), MENTIONS]
    problems = [
        f"{line}: `{text}` is in none of RUN, SLOW, NOT_RUN, MENTIONS"
        for line, text in spans()
        if not is_synopsis(text) and "..." not in text and sum(text in p for p in places) != 1
    ]
    named = [*places, set(ELIDED), set(INSTANCES)]
    problems += [f"`{text}` is no span of the README or the docs" for p in named for text in p - texts]
    assert not problems, "\n".join(problems)
    assert len(texts) > 50


def test_rig_s_parser_accepts_every_command(
    parser: argparse.ArgumentParser, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every span but a mention parses (a synopsis in each of its forms); a mention's subcommand
    and options are rig's. Parsed where the README's paths are (``--plot`` checks its folder)."""
    monkeypatch.chdir(ROOT)
    problems = []
    for line, text in spans():
        if text in MENTIONS:
            problems += [f"{line}: `{text}`: no {name}" for name in unknown_names(parser, text)]
            continue
        assert "..." not in text.replace("...]", "") or text in ELIDED, f"{line}: `{text}`: add to ELIDED"
        for form in forms(text) if is_synopsis(text) or text in ELIDED else [text]:
            why = refusal(parser, form)
            if why is not None:
                problems.append(f"{line}: `{text}`" + (f" as `{form}`" if form != text else "") + f": {why}")
    assert not problems, "\n".join(problems)


def test_a_renamed_option_or_subcommand_is_refused(parser: argparse.ArgumentParser) -> None:
    """The checks above catch what they are for."""
    assert refusal(parser, "rig design dtsm --a-m 16 --b-m 680 --period 4e-4 --lam -15 --error") is not None
    assert refusal(parser, "rig reproduce dismcc") is not None
    assert forms("rig scan (--interface I | --emulate PRESET) [--json]") == [
        "rig scan --emulate dc-servo",
        "rig scan --emulate dc-servo --json",
        "rig scan --interface socketcan",
        "rig scan --interface socketcan --json",
    ]
    assert unknown_names(parser, "rig emulate --devices") == ["--devices"]
    assert unknown_names(parser, "rig emulator") == ["emulator"]


@pytest.mark.parametrize("synopsis", sorted(INSTANCES), ids=lambda synopsis: INSTANCES[synopsis][0])
def test_a_form_does_what_the_readme_says(synopsis: str, tmp_path: pathlib.Path) -> None:
    command, check = INSTANCES[synopsis]
    _run_and_check(command, check, tmp_path, timeout=120, span=synopsis)


@pytest.mark.slow
@pytest.mark.timeout(1200)
@pytest.mark.parametrize("command", sorted(SLOW))
def test_the_slow_command_does_what_the_readme_says(command: str, tmp_path: pathlib.Path) -> None:
    _run_and_check(command, SLOW[command], tmp_path, timeout=900)


def _known_names() -> dict[str, set[str]]:
    """What the Commands table's lists name (a regex whose group holds them) -> rig's names."""
    from plant_emulator.presets import PRESETS
    from rig.papers.dismc import PARAM_NAMES
    from rig.papers.dq_current import DQ_PARAM_NAMES
    from rig.papers.drives_study import DRIVES_PARAM_NAMES

    return {
        r"`rig run \.\.\. --fault NAME=VALUE` \| inject a fault in a run: (.*?) \|": {
            f.name for f in dataclasses.fields(FaultsConfig)
        },
        r"\| `rig reproduce dismc .*?`--param` takes the paper's symbols \((.*?)\) \|": set(PARAM_NAMES),
        r"\| `rig reproduce drives .*?`--param` takes the horizons (.*?) \|": set(DRIVES_PARAM_NAMES),
        r"\| `rig reproduce dq-current .*?`--param` takes (.*?); `--json`": set(DQ_PARAM_NAMES),
        r"\| the plant emulator as its own process: presets (.*?); on a python-can bus": set(PRESETS),
    }


@pytest.mark.parametrize("pattern", sorted(_known_names()))
def test_the_names_a_row_lists_are_rig_s(pattern: str) -> None:
    """The fault names, the reproductions' --param names and the presets that the Commands table
    lists are rig's, all of them."""
    names = re.sub(r"\([^)]*\)", "", said(pattern)[1])  # values and asides in parentheses off
    listed = {code.split("=")[0] for code in re.findall(r"`([^`]+)`", names)}
    assert {name for name in listed if re.fullmatch(r"\w[\w-]*", name)} == _known_names()[pattern]


def _lines(text: str) -> str:
    return ", ".join(str(line) for line, t in spans() if t == text)


@pytest.mark.parametrize("command", sorted(RUN))
def test_the_command_does_what_the_readme_says(command: str, tmp_path: pathlib.Path) -> None:
    _run_and_check(command, RUN[command], tmp_path, timeout=120)


def _run_and_check(
    command: str, check: Check, folder: pathlib.Path, timeout: float, span: str | None = None
) -> None:
    # no display: `--live` draws its strip on stderr, as on a CI runner
    proc = run_here(f"env -u DISPLAY -u WAYLAND_DISPLAY {command}", folder, timeout=timeout)
    where = f"{_lines(span or command)}: `{command}`"
    assert proc.returncode == 0, (
        f"{where}: exit {proc.returncode}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    )
    try:
        check(proc, folder)
    except AssertionError as exc:
        raise AssertionError(f"{where}: {exc}\n{proc.stdout[-3000:]}") from exc


def _serve(*args: str) -> subprocess.Popen[str]:
    """``rig emulate ARGS`` as written: on the README's 127.0.0.1:29536."""
    proc, line = spawn_rig("emulate", *args, stderr=True)
    if "socketcand://127.0.0.1:29536" not in line:
        proc.kill()
        pytest.fail(f"rig emulate {' '.join(args)}: {line} {proc.communicate()[1][-2000:]}")
    return proc


@pytest.mark.timing
def test_the_emulator_serves_two_nodes(tmp_path: pathlib.Path) -> None:
    """`rig emulate --preset dc-servo` serves the drive (node 1) and the encoder (node 2) on
    127.0.0.1:29536, where rig scan over socketcand finds them; Ctrl-C stops it."""
    said(
        r"`rig emulate --preset dc-servo` serves the emulated drive \(node 1\) and encoder \(node 2\) "
        r"on 127\.0\.0\.1:29536"
    )
    server = _serve("--preset", "dc-servo")
    try:
        proc = run_here("rig scan --interface socketcand --channel can0 --json", tmp_path, timeout=60)
    finally:
        stop_rig(server, timeout=20)
    assert proc.returncode == 0, proc.stderr
    assert [row["node_id"] for row in json.loads(proc.stdout)] == [1, 2], proc.stdout
    assert server.returncode == 0


@pytest.mark.timing
def test_a_run_against_the_emulator_in_another_process(tmp_path: pathlib.Path) -> None:
    """ "The emulator": a copy of the servo example with `[run] period = 0.0004`, run with `rig run
    --config` beside `rig emulate --preset dc-servo --time lockstep --param load=pulse:0.0346:1.5:3`,
    gives the in-process result (rms 1.977 mrad)."""
    rms = said(r"beside `rig run --config` of the copy: .*? the in-process result exactly \(rms (N) mrad")[1]
    example = (ROOT / "examples/dc_servo_position.toml").read_text()
    (tmp_path / "servo.toml").write_text(example.replace("[run]\n", "[run]\nperiod = 0.0004\n", 1))
    server = _serve("--preset", "dc-servo", "--time", "lockstep", "--param", "load=pulse:0.0346:1.5:3")
    try:
        proc = run_here("rig run --config servo.toml", tmp_path, timeout=120)
    finally:
        stop_rig(server, timeout=20)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((run_dir(tmp_path, "dc-servo-position") / "summary.json").read_text())
    assert summary["cycles"] == 7500 and agree(rms, 1e3 * summary["rms_error"]), summary
