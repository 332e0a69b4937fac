from pathlib import Path

from click.testing import CliRunner

from experiments.cli import SUBCOMMANDS, main


def test_help_lists_every_subcommand() -> None:
    result = CliRunner().invoke(main, ["--help"])
    assert result.exit_code == 0
    for name in SUBCOMMANDS:
        assert name in result.output


def test_bad_goal_and_metric_options_name_the_option(tmp_path: Path) -> None:
    cases = (
        (["run", "longterm", "--metric", "bogus"], "--metric"),
        (["run", "boxpush", "--goal-velocity", "1"], "--goal-velocity"),
        (["run", "boxpush", "--retarget", "goal9@10s"], "no marker 'goal9'"),
        (["run", "longterm", "--retarget", "goal2@10s"], "--retarget is an option of boxpush"),
    )
    for args, needle in cases:
        result = CliRunner().invoke(main, [*args, "--out", str(tmp_path)])
        assert result.exit_code == 2, (args, result.output)
        assert needle in result.output
    assert not list(tmp_path.iterdir())  # nothing ran
