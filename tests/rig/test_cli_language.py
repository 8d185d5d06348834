"""One command language (issue 36 item 5): every ``rig`` parser walked against
``rig.cli.language``'s rules: one spelling per concept, the old ones deprecated aliases with one
warning line, options before or after an action, ``--json`` wherever a result is printed,
``--plot DIR`` made (and matplotlib checked) before anything runs, help pointing at the docs."""

from __future__ import annotations

import argparse
import pathlib
import re
import socket
from collections.abc import Iterator
from typing import Any

import pytest

from drivers.errors import ConfigError
from rig.cli import DOCS, build_parser, main
from rig.cli.language import SPELLINGS, SYNONYMS, Deprecated
from tests.patching import forget, stand_in

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: an option's dest -> the concept's one spelling (rig.cli.language.SPELLINGS)
CONCEPTS = {
    "emulate": "--emulate",
    "node": "--node",
    "interface": "--interface",
    "channel": "--channel",
    "bitrate": "--bitrate",
    "host": "--host",
    "port": "--port",
    "period": "--period",
    "plot": "--plot",
    "json": "--json",
    "param": "--param",
}
#: commands that print no result: a server (rig emulate's --json goes with --list)
NO_RESULT = {"rig view"}


def parsers() -> Iterator[tuple[list[str], argparse.ArgumentParser, bool]]:
    """(the words after rig, its parser, whether it has actions) for every command and action."""

    def walk(words: list[str], parser: argparse.ArgumentParser) -> Iterator[Any]:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        yield words, parser, bool(subs)
        for action in subs:
            for name, child in action.choices.items():
                yield from walk([*words, name], child)

    for words, parser, has_actions in walk([], build_parser()):
        if words:
            yield words, parser, has_actions


def own(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The options a parser declares (not those it takes from the command above its action)."""
    return [a for a in parser._actions if a.option_strings and not getattr(a, "inherited", False)]


def test_one_spelling_per_concept_on_every_parser() -> None:
    """A concept's option is spelt one way everywhere; a second spelling is only a deprecated
    alias of it."""
    problems, seen = [], set()
    for words, parser, _ in parsers():
        for action in own(parser):
            where = f"rig {' '.join(words)} {'/'.join(action.option_strings)}"
            if isinstance(action, Deprecated):
                for old in action.option_strings:
                    if SYNONYMS.get(old, action.new) != action.new:
                        problems.append(f"{where}: an alias of {action.new}, but {old} means {SYNONYMS[old]}")
                continue
            for option in action.option_strings:
                if option in SYNONYMS:
                    problems.append(f"{where}: {option} is a second spelling of {SYNONYMS[option]}")
            if action.dest in CONCEPTS:
                seen.add(action.dest)
                if CONCEPTS[action.dest] not in action.option_strings:
                    problems.append(f"{where}: spelt otherwise than {CONCEPTS[action.dest]}")
            if "--plot" in action.option_strings and action.metavar != "DIR":
                problems.append(f"{where}: --plot is a folder, DIR (metavar {action.metavar})")
            if "--emulate" in action.option_strings and action.metavar != "NAME":
                problems.append(f"{where}: --emulate takes a NAME (metavar {action.metavar})")
    assert not problems, "\n".join(problems)
    assert seen == set(CONCEPTS)  # every concept is somewhere, so each rule above was tried


def test_every_command_that_prints_a_result_takes_json() -> None:
    missing = [
        f"rig {' '.join(words)}"
        for words, parser, has_actions in parsers()
        if not has_actions
        and f"rig {' '.join(words)}" not in NO_RESULT
        and "--json" not in parser._option_string_actions
    ]
    assert not missing, f"no --json: {missing}"


def test_a_command_s_options_are_taken_after_its_action_too() -> None:
    """Every option of a command with actions is on each of its actions' parsers, at any depth;
    ``rig drive status --json`` is ``rig drive --json status``."""
    missing = []
    for words, parser, has_actions in parsers():
        if not has_actions:
            continue
        options = {o for a in own(parser) for o in a.option_strings} - {"-h", "--help", "-v", "--verbose"}
        for child_words, child, _ in parsers():
            if child_words[: len(words)] == words and len(child_words) > len(words):
                missing += [
                    f"rig {' '.join(child_words)} {o}" for o in options - set(child._option_string_actions)
                ]
    assert not missing, "not taken after the action: " + ", ".join(missing)
    parser = build_parser()
    before = parser.parse_args("drive --emulate epos4 --node 3 --json --units a=1 sdo read 0x6041".split())
    after = parser.parse_args("drive sdo read 0x6041 --emulate epos4 --node 3 --json --units a=1".split())
    both = parser.parse_args("drive --units a=1 --emulate epos4 status --json --units b=2".split())
    assert vars(before) == vars(after)
    assert (before.json, before.node, before.emulate) == (True, 3, "epos4")
    assert both.units == ["a=1", "b=2"] and both.json and both.emulate == "epos4"
    assert parser.parse_args("drive status".split()).json is False  # the default stands


def _required(parser: argparse.ArgumentParser) -> list[str]:
    """Words that fill a parser's required arguments (a choice's first, else 1)."""
    words: list[str] = []
    for action in parser._actions:
        if action.required and not getattr(action, "inherited", False):
            value = str(next(iter(action.choices))) if action.choices else "1"
            words += [action.option_strings[0], value] if action.option_strings else [value]
    return words


def deprecated_aliases() -> list[tuple[list[str], argparse.Action, str]]:
    return [
        (words, action, old)
        for words, parser, _ in parsers()
        for action in own(parser)
        if isinstance(action, Deprecated)
        for old in action.option_strings
    ]


def test_there_are_deprecated_aliases_to_walk() -> None:
    olds = {old for _, _, old in deprecated_aliases()}
    assert {"--dt", "--node-id", "--socketcand-port", "--modbus-port", "--listen"} <= olds


@pytest.mark.parametrize(
    ("words", "action", "old"),
    deprecated_aliases(),
    ids=[f"{' '.join(w)} {o}" for w, _, o in deprecated_aliases()],
)
def test_an_old_spelling_is_the_new_one_with_one_warning_line(
    words: list[str], action: Any, old: str, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = build_parser()
    leaf = dict((tuple(w), p) for w, p, _ in parsers())[tuple(words)]
    value = [] if action.nargs == 0 else ["7"]
    new = parser.parse_args([*words, *_required(leaf), action.new, *value])
    assert capsys.readouterr().err == ""
    aliased = parser.parse_args([*words, *_required(leaf), old, *value])
    err = capsys.readouterr().err
    assert getattr(aliased, action.dest) == getattr(new, action.dest)
    assert err.count("\n") == 1 and f"{old} is deprecated" in err and f"use {action.new}" in err
    assert err.startswith(f"rig {' '.join(words)}: ")


def test_emulate_s_param_period_is_the_old_period(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """rig emulate --param period= (the old spelling) is --period, with one warning line; both
    together is refused."""
    from rig.cli import emulate

    args = build_parser().parse_args(["emulate", "--preset", "dc-servo", "--period", "0.002"])
    assert emulate._period(args, {}) == {"period": "0.002"}
    assert capsys.readouterr().err == ""
    args = build_parser().parse_args(["emulate", "--preset", "dc-servo", "--param", "period=0.002"])
    assert emulate._period(args, {"period": "0.002"}) == {"period": "0.002"}
    assert capsys.readouterr().err.count("--param period= is deprecated") == 1
    assert main(["emulate", "--preset", "dc-servo", "--period", "0.002", "--param", "period=0.001"]) == 2
    assert "give --period" in capsys.readouterr().err


#: a command with --plot, and what it would run first (patched: it must find the folder made)
PLOTTED = [
    ("identify --emulate dc-servo", "rig.identify.experiment.run_experiment"),
    ("reproduce dismc", "rig.papers.dismc.run_dismc"),
    ("reproduce dq-current", "rig.papers.dq_current.dq_study"),
    ("reproduce drives", "rig.papers.drives_study.drives_study"),
    ("sweep examples/sweeps/servo_b_m.toml", "rig.sweep.engine.open_client"),
]


def test_every_plot_option_is_walked() -> None:
    plotted = {" ".join(w) for w, p, _ in parsers() if "--plot" in p._option_string_actions}
    assert plotted == {argv.split(" examples")[0].split(" --")[0] for argv, _ in PLOTTED}


class Ran(Exception):
    """The experiment was reached."""


@pytest.mark.parametrize(("argv", "experiment"), PLOTTED, ids=[a for a, _ in PLOTTED])
def test_plot_is_a_folder_made_before_the_experiment(
    argv: str, experiment: str, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--plot new/figures is made before the experiment starts (it was a FileNotFoundError after a
    15 s experiment)."""
    folder = tmp_path / "new" / "figures"
    made: list[bool] = []

    def experiment_starts(*args: Any, **kw: Any) -> Any:
        made.append(folder.is_dir())
        raise Ran

    stand_ins = [stand_in(monkeypatch, experiment, experiment_starts)]
    monkeypatch.chdir(ROOT)
    try:
        with pytest.raises(Ran):
            main([*argv.split(), "--plot", str(folder)])
    finally:
        forget(stand_ins)
    assert made == [True]


@pytest.mark.parametrize(("argv", "experiment"), PLOTTED, ids=[a for a, _ in PLOTTED])
def test_a_missing_matplotlib_is_said_before_the_experiment(
    argv: str,
    experiment: str,
    tmp_path: pathlib.Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """No matplotlib: one line, exit 2, and the experiment never started (its estimate was lost)."""

    def experiment_starts(*args: Any, **kw: Any) -> Any:
        raise Ran

    def no_pyplot() -> Any:
        raise ConfigError("plots need matplotlib: python -m pip install -e '.[plot]'")

    stand_ins = [
        stand_in(monkeypatch, experiment, experiment_starts),
        stand_in(monkeypatch, "rig.report.plots.require_pyplot", no_pyplot),
    ]
    monkeypatch.chdir(ROOT)
    try:
        assert main([*argv.split(), "--plot", str(tmp_path / "figures")]) == 2
    finally:
        forget(stand_ins)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "matplotlib" in err


def test_a_plot_file_name_is_refused_or_the_old_form_with_a_warning(
    tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Where --plot was a folder, x.png is refused (it quietly made a folder x.png); where it was a
    file, x.png is kept this release with one warning line and drawn to that file."""
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "drives", "--plot", "x.png"]) == 2
    assert "give a folder" in capsys.readouterr().err and not (tmp_path / "x.png").exists()
    assert main(["reproduce", "dismc", "--plot", "old.png", "--json"]) == 0
    err = capsys.readouterr().err
    assert err.count("is deprecated") == 1 and "--plot old.png" in err
    assert (tmp_path / "old.png").is_file()
    assert main(["reproduce", "dismc", "--plot", "figs", "--json"]) == 0
    assert (tmp_path / "figs" / "dismc.png").is_file()


def test_every_command_s_help_points_at_its_docs_page() -> None:
    parser = build_parser()
    pages = re.findall(r"docs/([\w-]+\.md)", parser.epilog or "")
    for words, child, _ in parsers():
        if len(words) == 1:
            assert f"docs/{DOCS[words[0]]}" in (child.epilog or ""), words
            pages += re.findall(r"docs/([\w-]+\.md)", child.epilog or "")
        assert not re.search(
            r"\b(rig|drivers|controllers|plant_emulator)/[\w/]+\.py\b", child.description or ""
        )
    assert pages and all((ROOT / "docs" / page).is_file() for page in pages)


def test_the_docs_table_is_the_language() -> None:
    """docs/cli.md gives each concept's one spelling and the old spellings it replaces."""
    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    for concept, (spelling, _) in SPELLINGS.items():
        assert re.search(rf"\| {re.escape(concept)} \| `{re.escape(spelling)}` \|", text), concept
    for old in SYNONYMS:
        assert f"`{old}`" in text, old


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.timeout(30)
@pytest.mark.parametrize("command", ["scan", "drive status"])
def test_a_connection_error_says_the_likely_cause_and_the_fix(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Nothing serves socketcand on the port: one line naming the server that is not there, and
    how to start one (it named an errno)."""
    port = str(_free_port())
    words = command.split()
    argv = [words[0], "--interface", "socketcand", "--channel", "can0", "--port", port, *words[1:]]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"127.0.0.1:{port}" in err and "is a socketcand server running there?" in err
    assert "rig emulate --device NAME" in err and "--host and --port" in err
