"""Python runs in subprocesses that start as the test session starts and that tests wait for.

A cold numba compilation takes a minute on one core. Started with the session (see
``pytest_collection_finish`` in ``conftest.py``), it runs beside the other tests on a
second core instead of after them. Tests that wait for a run carry the ``background_run``
mark, which puts them last, leaving the run the session to finish in.
"""

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


class BackgroundRun:
    """``python script <folder>`` in a subprocess, in a fresh folder, with extra environment.

    A test module lists its runs in ``BACKGROUND``; the session starts those of every
    module with a selected test marked ``background_run``. ``wait`` starts the run if
    nothing did, and returns the folder once the script exited with status 0; otherwise it
    raises with the script's standard error.
    """

    every = []  # every run made, which the session closes at its end

    def __init__(self, script, **env):
        self.script, self.env = script, env
        self.folder = self.process = self.stdout = self.stderr = None
        BackgroundRun.every.append(self)

    def start(self):
        if self.process is None:
            self.folder = Path(tempfile.mkdtemp(prefix="ndboundary-background-"))
            path = self.folder / "script.py"
            path.write_text(self.script)
            environ = {**os.environ, "NUMBA_CACHE_DIR": str(self.folder / "numba-cache"), **self.env}
            self.process = subprocess.Popen(
                [sys.executable, str(path), str(self.folder)],
                env=environ,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
        return self

    def wait(self, timeout=1200):
        self.start()
        if self.stdout is None:
            self.stdout, self.stderr = self.process.communicate(timeout=timeout)
        if self.process.returncode != 0:
            raise AssertionError(f"background run failed with status {self.process.returncode}:\n{self.stderr[-3000:]}")
        return self.folder

    def close(self):
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.communicate()
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)
