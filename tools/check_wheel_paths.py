"""Install ringqa from a wheel, run ``ringqa commission --example`` elsewhere, and check that no
absolute path (the installation, the home folder, the temporary folder, this checkout) appears
in what the run wrote (issue 27: paths in outputs name ``ringqa:data/...`` or the input's
folder, never an install path).

    python tools/check_wheel_paths.py               # the wheel unpacked into a temporary folder
    python tools/check_wheel_paths.py --fresh-venv  # ... into a fresh virtual environment
    python tools/check_wheel_paths.py --keep DIR    # keep the run's files in DIR

Steps: ``pip wheel . --no-deps`` builds the wheel; it is installed either into a temporary
folder (``pip install --no-deps --target``; the dependencies are this interpreter's, ringqa
comes first on ``PYTHONPATH``: about 20 s) or, with ``--fresh-venv``, into a new virtual
environment with its dependencies (from the index or ``--find-links`` pip is configured with:
the check then matches a user's install, minutes). ``ringqa --log-file run.log commission
--example --out example`` then runs in an empty folder elsewhere, and every text it wrote is
searched for the forbidden folders: ``results.json``, every CSV, the log, the PDF's text
(pypdfium2, else ``pdftotext``) and ``report.html``'s own text (its inlined plotly.js left out).
Prints each hit with the file and the line; exit status 0 when there is none.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: prints the folder ringqa is imported from (its site-packages)
WHERE = "import ringqa, pathlib; print(pathlib.Path(ringqa.__file__).parents[1])"


def build_wheel(dest: Path) -> Path:
    """``pip wheel . --no-deps`` of this checkout into ``dest``; the wheel's path."""
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "-q", "-w", str(dest)],
        check=True,
    )  # fmt: skip
    return next(dest.glob("ringqa-*.whl"))


def install(wheel: Path, where: Path, fresh_venv: bool) -> tuple[list[str], dict, Path]:
    """Install ``wheel``; return the command that runs ``ringqa``, its environment and the
    folder ringqa was installed into (its site-packages)."""
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if fresh_venv:
        venv = where / "venv"
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        py = venv / "bin" / "python"
        subprocess.run([str(py), "-m", "pip", "install", "-q", str(wheel)], check=True)
        site = subprocess.run(
            [str(py), "-c", WHERE],
            check=True, capture_output=True, text=True, env=env,
        ).stdout.strip()  # fmt: skip
        return [str(venv / "bin" / "ringqa")], env, Path(site)
    site = where / "site-packages"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(site),
         str(wheel)],
        check=True,
    )  # fmt: skip
    env["PYTHONPATH"] = str(site)
    return [sys.executable, "-m", "ringqa"], env, site


def forbidden(site: Path, work: Path) -> list[str]:
    """The folders no output may name (longest first)."""
    names = {str(site), str(site.resolve()), str(ROOT), str(Path(sys.prefix)), str(work)}
    home = str(Path.home())
    if home not in ("/", ""):
        names.add(home)
    names.add(tempfile.gettempdir())
    return sorted({n.rstrip("/") for n in names if n and n != "/"}, key=len, reverse=True)


def pdf_text(path: Path) -> str:
    """The PDF's text (pypdfium2, else pdftotext)."""
    try:
        import pypdfium2 as pdfium
    except ImportError:
        exe = shutil.which("pdftotext")
        if exe is None:
            raise SystemExit("no PDF text reader: install pypdfium2 or poppler-utils") from None
        return subprocess.run([exe, str(path), "-"], check=True, capture_output=True,
                              text=True).stdout  # fmt: skip
    doc = pdfium.PdfDocument(str(path))
    try:
        return "\n".join(doc[k].get_textpage().get_text_range() for k in range(len(doc)))
    finally:
        doc.close()


def html_text(path: Path) -> str:
    """report.html without its inlined scripts' bodies (plotly.js is a library, not output)."""
    text = path.read_text(encoding="utf-8")
    return re.sub(r"<script[^>]*>.*?</script>", "<script/>", text, flags=re.S)


def texts(out: Path, log: Path) -> dict[str, str]:
    """Name -> text of everything the run wrote that a reader sees."""
    found = {"run.log": log.read_text(encoding="utf-8")}
    for p in sorted(out.rglob("*")):
        rel = p.relative_to(out).as_posix()
        if p.suffix in (".json", ".csv", ".txt", ".toml"):
            found[rel] = p.read_text(encoding="utf-8-sig")
        elif p.suffix == ".pdf":
            found[rel + " (text)"] = pdf_text(p)
        elif p.suffix == ".html":
            found[rel + " (without scripts)"] = html_text(p)
    return found


def hits(found: dict[str, str], bad: list[str]) -> list[str]:
    """``file:line: text`` for each line that names a forbidden folder."""
    out = []
    for name, text in found.items():
        for k, line in enumerate(text.splitlines(), 1):
            for folder in bad:
                if folder in line:
                    out.append(f"{name}:{k}: {folder} in: {line.strip()[:200]}")
                    break
    return out


def check(fresh_venv: bool = False, keep: Path | None = None) -> tuple[list[str], dict[str, str]]:
    """Build, install, run and search (module docstring). Returns the hits and the texts."""
    with tempfile.TemporaryDirectory(prefix="ringqa-wheel-") as tmp:
        tmp = Path(tmp)
        wheel = build_wheel(tmp / "dist")
        cmd, env, site = install(wheel, tmp, fresh_venv)
        work = tmp / "elsewhere"
        work.mkdir()
        run = subprocess.run(
            [*cmd, "--log-file", "run.log", "commission", "--example", "--out", "example",
             "--quiet"],
            cwd=work, env=env, capture_output=True, text=True, check=False,
        )  # fmt: skip
        if run.returncode != 0:
            raise SystemExit(f"ringqa commission --example failed ({run.returncode}):\n"
                             f"{run.stderr[-3000:]}")  # fmt: skip
        out = work / "example"
        python = cmd[0] if len(cmd) > 1 else str(Path(cmd[0]).with_name("python"))
        probe = subprocess.run([python, "-c", "import ringqa; print(ringqa.__file__)"],
                               cwd=work, env=env, capture_output=True, text=True,
                               check=True)  # fmt: skip
        if not probe.stdout.strip().startswith(str(site)):  # the run used the installed copy
            raise SystemExit(f"ringqa was not taken from the wheel: {probe.stdout.strip()}")
        found = texts(out, work / "run.log")
        bad = forbidden(site, work)
        if keep is not None:
            shutil.copytree(work, keep, dirs_exist_ok=True)
        return hits(found, bad), found


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fresh-venv", action="store_true",
                    help="install into a new virtual environment, dependencies too")  # fmt: skip
    ap.add_argument("--keep", type=Path, default=None, help="copy the run's folder here")
    args = ap.parse_args(argv)
    found_hits, found = check(args.fresh_venv, args.keep)
    print(f"searched {len(found)} files: {', '.join(found)}")
    for h in found_hits:
        print(h)
    if found_hits:
        print(f"FAIL: {len(found_hits)} line(s) name an absolute path")
        return 1
    print("ok: no absolute path (installation, home, temporary folder, checkout) in the outputs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
