"""scripts/cwru_twin_study.py: its table of the committed reports is the committed one, and it never
writes a study into the committed folder (those reports are fixed inputs of the sim2real protocol)."""

import shutil
import subprocess
import sys

from bearingtwin.config import REPO_ROOT

SCRIPT = REPO_ROOT / "scripts" / "cwru_twin_study.py"
COMMITTED_TABLE = REPO_ROOT / "results" / "cwru_twin_study.md"


def study(*args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=cwd, capture_output=True, text=True, timeout=120)


def test_summarizing_the_committed_reports_gives_the_committed_table(tmp_path):
    table = tmp_path / "cwru_twin_study.md"
    shutil.copy(COMMITTED_TABLE, table)
    stale = table.read_text().replace("| 10.56 |", "| 99.99 |")  # record 97's baseline, for summarize to correct
    assert stale != table.read_text()
    table.write_text(stale)
    done = study("summarize", "--out", str(table), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert table.read_text() == COMMITTED_TABLE.read_text()


def test_a_study_is_never_run_into_the_committed_folder(tmp_path):
    done = study("run", "--out", str(REPO_ROOT / "results" / "cwru_twin_study" / "again"), cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.startswith("error: --out ") and len(done.stderr.splitlines()) == 1
    assert "committed reports" in done.stderr and list(tmp_path.iterdir()) == []
