"""The README and the user guide (docs/guide/*.md) stay true to the program.

The README is what a newcomer reads: short, its links and pictures there, its file formats table
naming every reader and exporter. The guide's command-line reference names every option of every
subcommand, every command line in the README or the guide names options the CLI has, and the
runnable examples (on bundled surfaces) print the summary line the docs show, up to its "...".
"""

from __future__ import annotations

import importlib
import re
import shlex
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
GUIDE = REPO / "docs" / "guide"
README_MAX_LINES = 250

# The documented CLI is `flatweave-cli ...` or `python -m flatweave ...`: the docs' commands are
# parsed and run by flatweave.cli (its build_parser and main).
CLI_MODULE = "flatweave.cli"
CLI_PREFIXES = ("flatweave-cli ", "python -m flatweave ")
# The window's command line, `flatweave ...`: flatweave.app.main.
APP_MODULE = "flatweave.app.main"
APP_PREFIX = "flatweave "


def cli():
    return importlib.import_module(CLI_MODULE)


def doc_pages() -> list[Path]:
    """The README, then every guide page."""
    return [README, *sorted(GUIDE.glob("*.md"))]


def docs_text() -> str:
    """The README and the guide, one text (the tests that look for a fact anywhere in the docs)."""
    return "\n\n".join(p.read_text(encoding="utf-8") for p in doc_pages())


def code_lines(page: Path) -> list[list[str]]:
    """The indented code blocks of a page, each a list of lines, backslash continuations joined."""
    blocks, block, pending = [], [], ""
    for line in page.read_text(encoding="utf-8").splitlines() + [""]:
        if line.startswith("        [") and block and not pending:
            block[-1] += " " + line.strip()  # a synopsis's continuation line
        elif line.startswith("    ") and line.strip():
            text = pending + line.strip()
            if text.endswith("\\"):
                pending = text[:-1] + " "
                continue
            block.append(text)
            pending = ""
        elif not line.strip() and block and pending == "":
            blocks.append(block)
            block = []
    return blocks


def cli_argv(line: str) -> list[str] | None:
    """The arguments of a documented command line, or None if it is not one."""
    for prefix in CLI_PREFIXES:
        if line.startswith(prefix):
            return shlex.split(line[len(prefix):])
    return None


def documented_commands() -> list[tuple[str, list[str], str | None]]:
    """(page name, argv, the output line shown under it or None) of every documented CLI line."""
    found = []
    for page in doc_pages():
        for block in code_lines(page):
            for k, line in enumerate(block):
                argv = cli_argv(line)
                if argv is None:
                    continue
                after = block[k + 1] if k + 1 < len(block) else None
                shown = after if after is not None and cli_argv(after) is None and " nodes, " in after else None
                found.append((page.name, argv, shown))
    return found


def subcommand_options() -> dict[str, set[str]]:
    """Every subcommand's option strings, from the CLI's own parser."""
    import argparse

    parser = cli().build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return {name: {s for a in p._actions for s in a.option_strings} for name, p in sub.choices.items()}


def github_slug(heading: str) -> str:
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    return {github_slug(m.group(1)) for m in re.finditer(r"^#+ (.+)$", page.read_text(encoding="utf-8"), re.M)}


def test_the_readme_is_short_and_the_guide_is_there():
    assert len(README.read_text(encoding="utf-8").splitlines()) < README_MAX_LINES
    for name in ("index", "composite-ply-from-step", "garment-panel-from-mesh", "darts", "exports", "cli",
                 "speed-and-accuracy"):
        assert (GUIDE / f"{name}.md").is_file(), name


@pytest.mark.parametrize("page", doc_pages(), ids=lambda p: p.name)
def test_links_and_pictures_resolve(page):
    """Every relative link and picture names a file that exists, and a #fragment a heading of it."""
    text = page.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):
            continue
        path, _, fragment = target.partition("#")
        where = (page.parent / path).resolve() if path else page
        assert where.exists(), f"{page.name}: {target} does not exist"
        if fragment:
            assert fragment in anchors(where), f"{page.name}: no heading #{fragment} in {where.name}"


def test_the_readme_formats_table_names_every_reader_and_exporter():
    from flatweave.export.registry import FORMATS  # flatweave's, once renamed
    from flatweave.reading.registry import suffixes

    text = README.read_text(encoding="utf-8")
    table = text[text.index("## File formats"):]
    table = table[:table.index("\n## ")]
    for suffix in [*suffixes(), *FORMATS]:
        assert f"`{suffix}`" in table, suffix


def test_the_cli_reference_names_every_option():
    text = (GUIDE / "cli.md").read_text(encoding="utf-8")
    for command, options in subcommand_options().items():
        assert f"## {command}" in text, command
        missing = sorted(o for o in options if o not in ("-h", "--help") and not re.search(re.escape(o) + r"\b", text))
        assert not missing, f"{command}: {missing}"


def test_documented_command_lines_use_real_options():
    """Every command line and synopsis in the docs names a subcommand and options it has."""
    options = subcommand_options()
    commands = documented_commands()
    assert len(commands) >= 8
    for page, argv, _ in commands:
        words = [w for w in argv if not w.startswith(("[", "-"))]
        if words[:1] == ["COMMAND"]:
            continue  # the synopsis of the program itself
        assert words and words[0] in options, f"{page}: {argv}"
        named = set(re.findall(r"--[a-z][\w-]*", " ".join(argv)))
        assert named <= options[words[0]] | {"--debug"}, f"{page}: {sorted(named - options[words[0]])}"


def test_documented_window_command_lines_use_real_options():
    parser = importlib.import_module(APP_MODULE).build_parser()
    options = {s for a in parser._actions for s in a.option_strings}
    lines = [line for page in doc_pages() for block in code_lines(page) for line in block
             if line.startswith(APP_PREFIX)]
    assert lines
    for line in lines:
        named = set(re.findall(r"--[a-z][\w-]*", line))
        assert named <= options, (line, sorted(named - options))


def runnable_examples():
    """The documented command lines on a bundled example with the summary line they print, once each."""
    from flatweave.reading.examples import example_names  # flatweave's, once renamed

    seen, out = set(), []
    for page, argv, shown in documented_commands():
        if shown and len(argv) > 1 and argv[1] in example_names() and tuple(argv) not in seen:
            seen.add(tuple(argv))
            out.append(pytest.param(argv, shown, id=f"{page}:{' '.join(argv[:4])}"))
    return out


@pytest.mark.parametrize("argv, shown", runnable_examples())
def test_documented_examples_print_what_the_docs_show(tmp_path, monkeypatch, capsys, argv, shown):
    monkeypatch.chdir(tmp_path)
    assert cli().main(argv) == 0
    captured = capsys.readouterr()
    summary = [line for line in (captured.out + captured.err).splitlines() if " nodes, " in line]
    expected = shown.split("...")[0].rstrip(", ")
    assert summary and summary[-1].startswith(expected), (summary, expected)
