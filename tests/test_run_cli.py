"""`bench run` chains the stages through their own command lines."""

import math
from pathlib import Path

import pytest

from drivebench.cli import build_parser
from drivebench.run_cli import FORWARDED, stage_commands, stage_parser


def test_every_stage_command_parses_with_that_stage_parser():
    # Truth: each stage's own argparse definition. A renamed or dropped flag in a stage
    # makes argparse exit (SystemExit), which fails this test.
    run_args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    commands = stage_commands(run_args)
    assert [c[0] for c in commands] == ["ingest", "fit", "optimize", "aep", "size", "report"]
    for argv in commands:
        args = build_parser(argv).parse_args(argv)
        assert args.command == argv[0]


def test_stage_outputs_feed_the_next_stage():
    run_args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    parsed = [build_parser(a).parse_args(a) for a in stage_commands(run_args)]
    ingest, fit, optimize, aep, size, report = parsed
    assert Path(ingest.store) == Path(fit.store) == Path(report.store) == Path("o/bench_store")
    assert Path(optimize.drive_model) == Path(fit.out) / "power_model.json"
    assert Path(report.fit) == Path(fit.out) and Path(report.optimize) == Path(optimize.out)
    assert optimize.trust
    assert Path(aep.optimize) == Path(optimize.out) and Path(report.aep) == Path(aep.out)
    assert aep.refine  # the demo's AEP comes from the adapted grid (docs/schemas.md §9)
    assert Path(size.drive_model) == Path(fit.out) / "power_model.json"
    assert Path(report.size) == Path(size.out)
    # the demo's site: Weibull k = 2, mean 5.5 m/s at 100 m (the paper's Leuven figure)
    for stage in (aep, size):
        assert (stage.weibull_k, stage.mean_speed, stage.height_m) == (2.0, 5.5, 100.0)


#: what `bench run` sets on purpose: the folders that chain the stages, the site, the
#: optimize wind grid covering it, --trust and --refine
SET_BY_RUN = {"paths", "store", "out", "fit", "optimize", "aep", "size", "drive_model",
              "weibull_k", "mean_speed", "height_m", "wind_grid", "trust", "refine"}


def test_bench_run_leaves_every_other_option_at_the_stages_default():
    run_args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    for argv in stage_commands(run_args):
        stage = argv[0]
        parsed = vars(stage_parser(stage).parse_args(argv[1:]))
        defaults = vars(stage_parser(stage).parse_args(
            [a for a in argv[1:2] if stage == "ingest"]))  # ingest needs its paths
        differ = {k for k in parsed if parsed[k] != defaults[k]} - SET_BY_RUN
        assert differ == set(), f"bench run changes bench {stage} {sorted(differ)}"
    # the size stage's scales are bench size's own (they once were typed again); its grid
    # covers the site (test below)
    size = stage_parser("size").parse_args(stage_commands(run_args)[4][1:])
    assert size.scales == stage_parser("size").get_default("scales")


@pytest.mark.parametrize("dest", sorted(FORWARDED))
def test_an_option_given_to_bench_run_reaches_its_stages(dest):
    stages, option = FORWARDED[dest]
    value = {"order": "3", "workers": "1", "size_scales": "1,2",
             "size_wind_grid": "6,8", "system": "optimize/data/systems/ap2.toml",
             "call_time_limit": "400"}[dest]
    flag = "--" + dest.replace("_", "-")
    run_args = build_parser(["run", "logs"]).parse_args(["run", "logs", flag, value])
    commands = {c[0]: c for c in stage_commands(run_args)}
    for stage in stages:
        argv = commands[stage]
        assert argv[argv.index(option) + 1] == value


def _energy_above(x: float, c: float) -> float:
    """The share of a Weibull k = 2 site's available wind energy above ``x`` [m/s], by
    quadrature of v^3 f(v) (independent of energy.site's incomplete gamma function)."""
    from scipy.integrate import quad

    def f(v):
        return v**3 * 2 * v / c**2 * math.exp(-((v / c) ** 2))

    return quad(f, x, 20 * c)[0] / quad(f, 0, 20 * c)[0]


def test_default_wind_grid_covers_99_percent_of_the_site_wind_energy():
    run_args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    optimize = stage_commands(run_args)[2]
    start, stop, step = (float(x) for x in optimize[optimize.index("--wind-grid") + 1].split(":"))
    # bench optimize's default 4:10:1.5 starts and steps the grid
    assert (start, step) == (4.0, 1.5)
    # Weibull k = 2, mean 5.5 m/s (the site is given at the 100 m reference height, so
    # unmoved), scale c = 5.5 / Gamma(1.5)
    c = 5.5 / math.gamma(1.5)
    assert _energy_above(stop, c) < 0.01 <= _energy_above(stop - step, c)
    assert stop == 17.5  # 99 % of the energy lies below 17.04 m/s, rounded up to the grid


AP2 = "optimize/data/systems/ap2.toml"


def test_bench_run_flies_your_kite_and_drive():
    # issue 49: bench run had no --system and no --drive-model ("unrecognized arguments")
    run_args = build_parser(["run", "logs"]).parse_args(
        ["run", "logs", "--system", AP2, "--drive-model", "drive.json"])
    commands = {c[0]: build_parser(c).parse_args(c) for c in stage_commands(run_args)}
    for stage in ("optimize", "size"):
        assert str(commands[stage].system) == AP2
        assert Path(commands[stage].drive_model) == Path("drive.json")


def test_bench_run_sizes_on_bench_size_own_grid_as_the_readme_does():
    # issue 49: make demo sized on 4:13:3 and the README's `bench size` on 5.5,7,8.5, and
    # they named different drives for the same site. Both now leave the grid and the scales
    # to bench size, whose grid covers the site (tests/test_sizing_decision.py)
    import re
    import shlex

    run_args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    ours = stage_commands(run_args)[4]
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")
    line = re.search(r"^bench size [^#\n]*", readme, re.M).group(0)
    theirs = shlex.split(line)[1:]  # without "bench"
    parsed = [stage_parser("size").parse_args(a[1:]) for a in (ours, theirs)]
    keys = ("wind_grid", "scales", "weibull_k", "mean_speed", "system", "tolerance", "extend")
    assert [{k: getattr(p, k) for k in keys} for p in parsed][0] == {
        k: getattr(parsed[1], k) for k in keys}
    assert parsed[0].wind_grid is None  # bench size's default: the grid that covers the site
    assert parsed[1].height_m in (None, 100.0)  # at the 100 m reference height, as bench run


def test_optimize_exit_codes_and_bench_run_going_on_past_some_failures(monkeypatch, capsys):
    import drivebench.cli
    from drivebench.run_cli import run
    from optimize.cli import EXIT_CODES, exit_code

    assert exit_code([True, True]) == 0
    assert exit_code([True, False]) == 3
    assert exit_code([False, False]) == 1
    # the codes are in bench optimize --help
    help_text = build_parser(["optimize"])._subparsers._group_actions[0].choices[
        "optimize"].format_help()
    assert " ".join(EXIT_CODES.split()) in " ".join(help_text.split())
    # bench run goes on past an optimize with some failed scenarios, stops on any other code
    calls = []

    def fake_main(argv):
        calls.append(argv[0])
        return {"optimize": 3, "size": 1}.get(argv[0], 0)

    monkeypatch.setattr(drivebench.cli, "main", fake_main)
    args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    assert run(args) == 1
    assert calls == ["ingest", "fit", "optimize", "aep", "size"]
    assert "some scenarios failed" in capsys.readouterr().out
