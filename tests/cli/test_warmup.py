"""The compile notice (ringqa/cli/_jit.py) and ``ringqa warmup``."""

from __future__ import annotations

import io

from numba import njit

from ringqa.cli import main
from ringqa.cli._jit import compile_notice, kernel_label


def test_notice_printed_on_a_compile_and_silent_when_compiled():
    """A kernel compiled inside the block: the notice and one progress line naming it; the same
    kernel called again (compiled: what a warm cache looks like to numba's compile event): no
    output at all."""

    @njit(cache=False)
    def twice(x):
        return 2.0 * x

    out = io.StringIO()
    with compile_notice(out) as lis:
        assert twice(1.5) == 3.0
    text = out.getvalue()
    assert "compiling the numerical kernels once" in text
    assert "later runs" in text
    assert [label for label, _ in lis.compiled] == [f"{__name__}: twice"]
    assert text.count("compiled ") == 1

    out2 = io.StringIO()
    with compile_notice(out2) as lis2:
        assert twice(2.5) == 5.0
    assert out2.getvalue() == ""
    assert lis2.compiled == []


def test_kernel_label_names_the_effects_of_newton():
    """Newton's specialisation is named by the effects in its args tuple (each once, in order),
    other kernels by group and function."""

    class Disp:
        def __init__(self, fn):
            self.py_func = fn

    def newton():  # stands in for ringqa.simulation.solvers.newton.newton
        pass

    newton.__module__ = "ringqa.simulation.solvers.newton"
    args = "(Tuple((AxialArgs(array), ContactArgs(ChannelArgs(float64)), TetherArgs(f))), q)"
    assert kernel_label(Disp(newton), args) == "simulation: newton (axial, contact, tether)"

    def rows():
        pass

    rows.__module__ = "tg43._kernels"
    assert kernel_label(Disp(rows), "(int64,)") == "TG-43 dose: rows"


def test_warmup_command(capsys):
    """``ringqa warmup`` runs the commissioning scene of both cable presets commission picks
    (Flexitron, microSelectron) and says so on stdout."""
    assert main(["warmup"]) == 0
    out = capsys.readouterr().out
    assert "flexitron, microselectron cables" in out
