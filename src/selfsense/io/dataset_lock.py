"""One import into a dataset at a time: the dataset's lock, ``raw/<dataset>/.import.lock``.

An import reads the dataset's manifest, checks its capture against it and writes both; two imports
into one dataset at once would each miss the other's experiment. So an import holds the lock
(``fcntl.flock``, exclusive) from before it reads the manifest until the manifest is written, and
imports into one dataset run one after another; a killed import's lock goes with its process. The
dataset's folder is made for the lock, and removed again if the import that made it fails and
leaves it empty.
"""

from __future__ import annotations

import fcntl
import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from selfsense.io.sources import ImportProblem

#: how long an import waits for another import into the same dataset to finish [s]
LOCK_TIMEOUT_S = 600.0
LOCK_NAME = ".import.lock"


@contextmanager
def dataset_lock(folder: Path, timeout: float = LOCK_TIMEOUT_S) -> Iterator[None]:
    """Hold ``folder/.import.lock`` (``fcntl.flock``, exclusive), waiting up to ``timeout`` s.

    The folder is made if need be, and removed again on leaving if this import made it and left
    it empty (a failed import into a new dataset). The lock file is removed while it is held:
    an import waiting on it then finds, once it has the lock, that the name no longer leads to
    the file it holds, and takes the lock again on the new file (so two never hold it at once).
    A killed import's lock is released by the kernel with its process.
    """
    path = folder / LOCK_NAME
    made: list[Path] = []
    deadline = time.monotonic() + timeout
    while True:
        made += _make_folders(folder)
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except FileNotFoundError:  # another import removed the folder it had made: again
            continue
        try:
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        raise ImportProblem(
                            f"{path}: another import into dataset {folder.name} still runs "
                            f"after {timeout:g} s: try again when it has finished"
                        ) from None
                    time.sleep(0.05)
            try:
                held, named = os.fstat(fd), os.stat(path)
                current = (held.st_dev, held.st_ino) == (named.st_dev, named.st_ino)
            except FileNotFoundError:
                current = False
        except BaseException:
            os.close(fd)
            raise
        if current:
            break
        os.close(fd)  # the lock file was removed by the import before us: take the new one
    try:
        yield
    finally:
        path.unlink(missing_ok=True)
        for made_folder in reversed(made):
            try:
                made_folder.rmdir()  # only if empty: this import failed into a new dataset
            except OSError:
                break
        os.close(fd)


def _make_folders(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents; the ones made, outermost first."""
    missing = []
    for parent in [folder, *folder.parents]:
        if parent.exists():
            break
        missing.append(parent)
    made = []
    for parent in reversed(missing):
        try:
            parent.mkdir()
            made.append(parent)
        except FileExistsError:
            pass
    return made
