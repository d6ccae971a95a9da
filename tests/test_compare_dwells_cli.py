"""benchmarks/compare_dwells.py's command line: usage and refusals, never a traceback."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def tool(load_script):
    return load_script("benchmarks/compare_dwells.py")


def test_help_lists_the_modes_and_scenes(tool, capsys):
    with pytest.raises(SystemExit) as exc:
        tool.parse_args(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "{save,compare}" in out and "ring13_torsion" in out and "oncentra_example_ring" in out


@pytest.mark.parametrize(
    ("argv", "word"),
    [
        ([], "required"),
        (["compre", "DIR"], "invalid choice: 'compre'"),
        (["save", "DIR", "no_such_scene"], "unknown scene(s): no_such_scene"),
        (["compare", "{missing}"], "no such folder"),
    ],
)
def test_wrong_arguments_are_refused_with_usage(tool, capsys, tmp_path, argv, word):
    argv = [a.replace("{missing}", str(tmp_path / "missing")) for a in argv]
    with pytest.raises(SystemExit) as exc:
        tool.parse_args(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: compare_dwells.py") and word in err


def test_right_arguments_parse(tool, tmp_path):
    args = tool.parse_args(["compare", str(tmp_path), "ring13_torsion"])
    assert (args.mode, args.dir, args.scenes) == ("compare", tmp_path, ["ring13_torsion"])
    assert tool.parse_args(["save", str(tmp_path / "new")]).scenes == []
