"""The README's Python snippets run as written (from the repository root)."""

import os
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def test_every_python_snippet_of_the_readme_runs(capsys):
    text = (REPO / "README.md").read_text()
    snippets = re.findall(r"```python\n(.*?)```", text, re.S)
    assert snippets, "the README has Python snippets"
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        for code in snippets:
            exec(compile(code, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)
    assert capsys.readouterr().out.strip()
