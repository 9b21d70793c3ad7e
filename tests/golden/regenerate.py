"""Regenerate the golden CSVs (``python -m tests.golden.regenerate``) after an intended change of behaviour."""

import tempfile
from pathlib import Path

from tests.golden.cases import DATA, run_all, store

if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as workdir:
        store(run_all(Path(workdir)))
    print(f"wrote {DATA}")
