"""`bench run` chains the stages through their own command lines."""

from pathlib import Path

from bench.cli import build_parser
from bench.run_cli import stage_commands


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


def test_optimize_exit_codes_and_bench_run_going_on_past_some_failures(monkeypatch, capsys):
    import bench.cli
    from bench.run_cli import run
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

    monkeypatch.setattr(bench.cli, "main", fake_main)
    args = build_parser(["run", "logs"]).parse_args(["run", "logs", "--out", "o"])
    assert run(args) == 1
    assert calls == ["ingest", "fit", "optimize", "aep", "size"]
    assert "some scenarios failed" in capsys.readouterr().out
