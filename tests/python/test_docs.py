"""Every ```python block of docs/python.md runs, in order, as a reader would
paste them into one session: one namespace shared by the blocks, the working
directory a temporary one in which `tools/` is the repository's (so that
"tools/scenes/seed_cantilever.toml" resolves, and the files the snippets
write land in the temporary directory).

One test per block, named by its first line in docs/python.md; a failure
gives that line, and the traceback's line numbers are docs/python.md's.
Run by ctest with the rest of tests/python (python_module).
"""

import os
import re
import traceback

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DOC = os.path.join(ROOT, "docs", "python.md")


def python_blocks(path):
    """(first line of the code, its text) of each ```python block, in order."""
    blocks, lines = [], open(path, encoding="utf-8").read().split("\n")
    i = 0
    while i < len(lines):
        if re.match(r"^```python\s*$", lines[i]):
            start = i + 2  # 1-based number of the block's first code line
            body = []
            i += 1
            while i < len(lines) and not lines[i].startswith("```"):
                body.append(lines[i])
                i += 1
            if i == len(lines):
                raise ValueError(f"{path}:{start - 1}: a ```python block is not closed")
            blocks.append((start, "\n".join(body)))
        i += 1
    return blocks


BLOCKS = python_blocks(DOC)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """The blocks' shared namespace and working directory, and how many have run."""
    work = tmp_path_factory.mktemp("docs")
    os.symlink(os.path.join(ROOT, "tools"), work / "tools")
    return {"namespace": {"__name__": "__docs__"}, "cwd": str(work), "ran": 0, "failed": None}


def run_block(state, index):
    line, code = BLOCKS[index]
    # pad so that the traceback's line numbers are docs/python.md's
    compiled = compile("\n" * (line - 1) + code, DOC, "exec")
    old = os.getcwd()
    os.chdir(state["cwd"])
    try:
        exec(compiled, state["namespace"])
    except Exception:
        state["failed"] = line
        pytest.fail(f"docs/python.md:{line}: the ```python block starting here failed:\n{traceback.format_exc()}",
                    pytrace=False)
    finally:
        os.chdir(old)


def test_the_docs_have_python_blocks():
    assert len(BLOCKS) >= 3, "docs/python.md: no ```python blocks found"


@pytest.mark.parametrize("index", range(len(BLOCKS)), ids=[f"line-{line}" for line, _ in BLOCKS])
def test_a_docs_python_block_runs(session, index):
    # the blocks before this one first (when run alone, e.g. with -k line-NN)
    if session["failed"] is not None:
        pytest.skip(f"an earlier block (docs/python.md:{session['failed']}) failed")
    while session["ran"] <= index:
        i = session["ran"]
        session["ran"] += 1
        run_block(session, i)
