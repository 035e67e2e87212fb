"""The guide's "From Python" example runs as written: the twin, the signal functions, a real record's features
and a classifier fitted and scored in a script."""

import re

import pytest

from bearingtwin.config import REPO_ROOT, data_root

DATA = data_root()


@pytest.mark.skipif(not (DATA / "cwru" / "normal_0_97.mat").is_file(), reason=f"CWRU records not found in {DATA}")
def test_the_guides_python_example_runs_and_reads_what_it_says(tmp_path, monkeypatch, capsys):
    guide = (REPO_ROOT / "docs" / "guide.md").read_text()
    section = guide[guide.index("## From Python"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(tmp_path)  # the example writes nothing: checked below
    monkeypatch.setenv("BEARINGTWIN_DATA", str(DATA))
    exec(compile(code, "docs/guide.md", "exec"), {"__name__": "guide"})
    printed = capsys.readouterr().out.splitlines()
    bpfo, line = map(float, re.search(r"BPFO ([\d.]+) Hz, envelope line at ([\d.]+) Hz", printed[0]).groups())
    assert line == pytest.approx(bpfo, abs=1.0)  # the simulated outer race shows its defect frequency
    state, share = re.fullmatch(r"(\w+): (\d+)% of the windows", printed[1]).groups()
    assert state == "outer" and int(share) >= 90  # a load the classifier did not see, read right
    assert list(tmp_path.iterdir()) == []
