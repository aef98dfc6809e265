"""io.runlog: what a pipeline script prints goes to its rule's log, appended."""

from __future__ import annotations

import logging
import re
import sys

from microdoppler.io.runlog import log_to, progress


def test_log_to_appends_stdout_stderr_and_logging_then_restores_them(tmp_path):
    path = tmp_path / "logs" / "rule" / "job.log"  # the folders are made
    handlers = list(logging.getLogger().handlers)
    with log_to(path) as fh:
        print("printed")
        print("to stderr", file=sys.stderr)
        logging.getLogger("microdoppler.test").info("logged")
        assert sys.stdout is fh and sys.stderr is fh
    assert sys.stdout is not fh and sys.stderr is not fh
    assert logging.getLogger().handlers == handlers
    with log_to(path):
        print("second run")
    lines = path.read_text().splitlines()
    assert lines[:2] == ["printed", "to stderr"]
    assert re.fullmatch(r".+ INFO microdoppler\.test: logged", lines[2]), lines[2]
    assert lines[3:] == ["second run"]


def test_progress_prints_at_every_step_and_at_the_end(capsys):
    cb = progress("fit", every=0.25)
    for done in range(11):
        cb(done, 10)
    lines = capsys.readouterr().out.splitlines()
    assert [re.search(r"\((\d+)/10\)$", s).group(1) for s in lines] == ["0", "3", "6", "9", "10"]
    assert all(s.startswith("fit: ") for s in lines)
    assert lines[-1] == "fit: 100.0% (10/10)"
    progress("empty")(0, 0)  # no work at all: done, not a division by zero
    assert re.fullmatch(r"empty: +0\.0% \(0/0\)", capsys.readouterr().out.strip())
