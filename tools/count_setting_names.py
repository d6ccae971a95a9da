"""How many places write a commissioning setting's name? (issue 30's code-review figure)

    python tools/count_setting_names.py [ROOT ...]

For each setting below, counts the string literals in ``ROOT/ringqa/**/*.py`` (docstrings left
out; tests and docs are outside ``ringqa/``) that spell one of its names: the configuration key
(``simulation.register``), the option (``--register``, ``--no-...``), the field / results.json
key / key name as a bare string (``"register"``). Python attribute access (``settings.register``)
is not counted: it is checked by the interpreter, a string is not. ROOT defaults to this
checkout; give an old checkout (``git archive <commit> ringqa | tar -x -C DIR``) to compare.
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from pathlib import Path

SPELLINGS = {
    "register": {"simulation.register", "--register", "register"},
    "strict": {"report.strict", "--strict", "strict"},
    "cross_check": {"simulation.cross_check", "--cross-check", "--no-cross-check", "cross_check"},
    "sk_u": {"simulation.sk_u", "--sk-u", "sk_u", "sk_U"},
    "stem_mm": {"simulation.stem_mm", "--stem-mm", "stem_mm"},
}


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def count(root: Path) -> dict[str, Counter]:
    """Setting -> Counter of files (relative to ``root``) -> literals naming it."""
    found = {name: Counter() for name in SPELLINGS}
    for path in sorted((root / "ringqa").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = _docstrings(tree)
        rel = str(path.relative_to(root))
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if id(node) in docs:
                    continue
                for name, spellings in SPELLINGS.items():
                    if node.value in spellings:
                        found[name][rel] += 1
    return found


def main(argv: list[str]) -> int:
    roots = [Path(a) for a in argv] or [Path(__file__).resolve().parents[1]]
    for root in roots:
        print(f"{root}:")
        for name, where in count(root).items():
            files = ", ".join(f"{k} {v}" for k, v in where.items())
            print(f"  {name}: {sum(where.values())} literals in {len(where)} files ({files})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
