"""One language for the command line (issue 42): docs/cli.md is the table of every option
of every stage as the parsers define it, and one idea has one name across the stages."""

from __future__ import annotations

from pathlib import Path

from drivebench.cli_doc import cli_markdown, option_rows, stage_parsers

DOC = Path(__file__).resolve().parent.parent / "docs" / "cli.md"
#: the stages that show a progress bar (tqdm), each of which must take --no-progress
BAR_STAGES = ("synth", "ingest", "fit", "optimize", "aep", "size", "run")
#: names that said an idea another stage names otherwise -> the name in use
RETIRED = {"--quiet": "--no-progress", "--site-height-m": "--height-m",
           "--rated-torque-nm": "--continuous-torque-nm", "--overload": "--max-torque-nm",
           "optimize_out": "--optimize"}


def _options() -> dict[str, set[str]]:
    return {name: {o.strip("`") for row in option_rows(p) for o in row[0].split(", ")}
            for name, p in stage_parsers()}


def test_docs_cli_md_is_the_parsers_table():
    # regenerate with: python -m drivebench.cli_doc > docs/cli.md
    assert DOC.read_text(encoding="utf-8") == cli_markdown()


def test_every_stage_with_a_bar_takes_no_progress():
    options = _options()
    assert [s for s in BAR_STAGES if "--no-progress" not in options[s]] == []


def test_one_idea_one_name():
    used = {o: s for s, opts in _options().items() for o in opts}
    assert {o: used[o] for o in RETIRED if o in used} == {}
    # an option every stage spells alike says so alike: the help of --no-progress, --out
    for name, p in stage_parsers():
        for option, _, _, text in option_rows(p):
            if option == "`--no-progress`":
                assert text.startswith("no progress bar"), (name, text)
            assert text, (name, option)  # every option says what it is
