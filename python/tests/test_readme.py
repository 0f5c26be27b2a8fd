"""The README's Python quick start runs after `pip install` (its ```python blocks, in order,
in one namespace; the pyMOR block when pyMOR is installed)."""

import os

import pytest

README = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "README.md")


def python_blocks():
    blocks, current = [], None
    with open(README) as f:
        for line in f:
            if current is None and line.strip() == "```python":
                current = []
            elif current is not None and line.strip() == "```":
                blocks.append("".join(current))
                current = None
            elif current is not None:
                current.append(line)
    return blocks


def test_readme_quick_start_runs(capsys):
    blocks = python_blocks()
    assert len(blocks) == 2, "the quick start and the pyMOR block"
    namespace = {}
    exec(compile(blocks[0], "README quick start", "exec"), namespace)
    out = capsys.readouterr().out
    assert "order" in out and "error" in out, out
    pytest.importorskip("pymor")
    exec(compile(blocks[1], "README pyMOR block", "exec"), namespace)
    out = capsys.readouterr().out
    assert "pyMOR: |H - Hr| / |H| =" in out, out
